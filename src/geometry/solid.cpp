#include "geometry/solid.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>
#include <fmt/format.h>

namespace capsflow::geometry {

namespace {

// x's coordinates about an axis (unit vector through `centre`): along it and from it.
struct Meridian {
  double s = 0.0, rho = 0.0;
};
Meridian meridian(const Eigen::Vector3d& x, const Eigen::Vector3d& centre, const Eigen::Vector3d& unit_axis) {
  const Eigen::Vector3d r = x - centre;
  const double s = r.dot(unit_axis);
  return {s, (r - s * unit_axis).norm()};
}

class Box final : public Solid {
 public:
  Box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) : centre_((lo + hi) / 2), half_((hi - lo) / 2) {}
  double signed_distance(const Eigen::Vector3d& x) const override {
    // Per axis, how far beyond the box's faces x lies (negative: inside that slab).
    const Eigen::Vector3d q = (x - centre_).cwiseAbs() - half_;
    return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  }

 private:
  Eigen::Vector3d centre_, half_;
};

class Sphere final : public Solid {
 public:
  Sphere(const Eigen::Vector3d& centre, double radius) : centre_(centre), radius_(radius) {}
  double signed_distance(const Eigen::Vector3d& x) const override { return (x - centre_).norm() - radius_; }

 private:
  Eigen::Vector3d centre_;
  double radius_;
};

class CylinderSolid final : public Solid {
 public:
  explicit CylinderSolid(const Cylinder& c) : c_(c) { c_.axis.normalize(); }
  double signed_distance(const Eigen::Vector3d& x) const override {
    const auto [s, rho] = meridian(x, c_.centre, c_.axis);
    if (!(c_.half_length > 0.0)) return rho - c_.radius;
    if (c_.rounded_ends) {                           // from the axis segment
      const double beyond = std::max(std::abs(s) - c_.half_length, 0.0);
      return std::hypot(rho, beyond) - c_.radius;
    }
    // In the meridian half-plane (|s|, rho) the solid is a rectangle.
    const double a = rho - c_.radius, b = std::abs(s) - c_.half_length;
    return std::hypot(std::max(a, 0.0), std::max(b, 0.0)) + std::min(std::max(a, b), 0.0);
  }

 private:
  Cylinder c_;
};

class TubeWall final : public Solid {
 public:
  explicit TubeWall(const Tube& t) : t_(t) { t_.axis.normalize(); }
  double signed_distance(const Eigen::Vector3d& x) const override {
    const auto [s, rho] = meridian(x, t_.centre, t_.axis);
    const double d = std::sqrt(squared_distance(s, rho));
    return rho < radius(s) ? d : -d;  // the fluid inside the tube is positive
  }

 private:
  static constexpr double kPi = 3.14159265358979323846;
  double radius(double s) const {
    if (std::abs(s) >= t_.half_length) return t_.far_radius;
    return t_.far_radius + (t_.throat_radius - t_.far_radius) * 0.5 * (1.0 + std::cos(kPi * s / t_.half_length));
  }
  double slope(double s) const {
    if (std::abs(s) >= t_.half_length) return 0.0;
    return -(t_.throat_radius - t_.far_radius) * 0.5 * kPi / t_.half_length * std::sin(kPi * s / t_.half_length);
  }
  double curvature(double s) const {
    if (std::abs(s) >= t_.half_length) return 0.0;
    const double k = kPi / t_.half_length;
    return -(t_.throat_radius - t_.far_radius) * 0.5 * k * k * std::cos(k * s);
  }
  // min over the profile's points (u, R(u)) of the squared distance to (s, rho) in the
  // meridian half-plane. Where R is constant (|u| >= L) the nearest point is u = s clamped
  // into that part; on the blend samples find the basin and Newton on the derivative
  // polishes it (kept between the neighbouring samples).
  double squared_distance(double s, double rho) const {
    const double L = t_.half_length;
    auto f = [&](double u) { return (s - u) * (s - u) + (rho - radius(u)) * (rho - radius(u)); };
    const double best = std::min({f(std::min(s, -L)), f(std::max(s, L)), f(std::clamp(s, -L, L))});
    // A nearer point lies within sqrt(best) of s along the axis: sample only that part of
    // the blend (most points far from the throat need none).
    const double reach = std::sqrt(best), from = std::max(s - reach, -L), to = std::min(s + reach, L);
    if (!(from < to)) return best;
    constexpr int kSamples = 64;
    const double step = (to - from) / kSamples;
    double best_u = from, sampled = f(from);
    for (int k = 1; k <= kSamples; ++k) {
      const double u = from + k * step;
      if (const double v = f(u); v < sampled) {
        sampled = v;
        best_u = u;
      }
    }
    double u = best_u;
    const double lo = std::max(best_u - step, from), hi = std::min(best_u + step, to);
    for (int it = 0; it < 30; ++it) {
      const double g = -(s - u) - (rho - radius(u)) * slope(u);
      const double h = 1.0 + slope(u) * slope(u) - (rho - radius(u)) * curvature(u);
      if (!(h > 0.0)) break;
      const double next = std::clamp(u - g / h, lo, hi);
      if (next == u) break;
      u = next;
    }
    return std::min({best, sampled, f(u)});
  }
  Tube t_;
};

// min (union) or max (intersection) over the parts.
class Combination final : public Solid {
 public:
  Combination(std::vector<SolidPtr> parts, bool union_of_parts) : parts_(std::move(parts)), union_(union_of_parts) {}
  double signed_distance(const Eigen::Vector3d& x) const override {
    double d = parts_.front()->signed_distance(x);
    for (std::size_t i = 1; i < parts_.size(); ++i) {
      const double e = parts_[i]->signed_distance(x);
      d = union_ ? std::min(d, e) : std::max(d, e);
    }
    return d;
  }
  Eigen::Vector3d wall_velocity(const Eigen::Vector3d& x) const override {
    const Solid* nearest = parts_.front().get();
    double distance = std::abs(nearest->signed_distance(x));
    for (std::size_t i = 1; i < parts_.size(); ++i)
      if (const double e = std::abs(parts_[i]->signed_distance(x)); e < distance) {
        distance = e;
        nearest = parts_[i].get();
      }
    return nearest->wall_velocity(x);
  }
  bool moves() const override {
    return std::any_of(parts_.begin(), parts_.end(), [](const SolidPtr& p) { return p->moves(); });
  }

 private:
  std::vector<SolidPtr> parts_;
  bool union_;
};

class MovingWall final : public Solid {
 public:
  MovingWall(SolidPtr s, const WallMotion& m) : s_(std::move(s)), m_(m) {}
  double signed_distance(const Eigen::Vector3d& x) const override { return s_->signed_distance(x); }
  Eigen::Vector3d wall_velocity(const Eigen::Vector3d& x) const override {
    return m_.velocity + m_.angular_velocity.cross(x - m_.centre);
  }
  bool moves() const override { return true; }

 private:
  SolidPtr s_;
  WallMotion m_;
};

class Complement final : public Solid {
 public:
  explicit Complement(SolidPtr s) : s_(std::move(s)) {}
  double signed_distance(const Eigen::Vector3d& x) const override { return -s_->signed_distance(x); }
  Eigen::Vector3d wall_velocity(const Eigen::Vector3d& x) const override { return s_->wall_velocity(x); }
  bool moves() const override { return s_->moves(); }

 private:
  SolidPtr s_;
};

void check_finite(const Eigen::Vector3d& v, const char* what) {
  if (!v.allFinite()) throw std::invalid_argument(fmt::format("geometry: {} is not finite", what));
}

void check_parts(const std::vector<SolidPtr>& parts, const char* what) {
  if (parts.empty()) throw std::invalid_argument(fmt::format("geometry: {} of no solids", what));
  for (const SolidPtr& p : parts)
    if (!p) throw std::invalid_argument(fmt::format("geometry: {} of a missing solid", what));
}

}  // namespace

SolidPtr box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  check_finite(lo, "a box corner");
  check_finite(hi, "a box corner");
  for (int d = 0; d < 3; ++d)
    if (!(lo[d] < hi[d]))
      throw std::invalid_argument(fmt::format("geometry: box corners {} and {} along axis {} (need lo < hi)", lo[d], hi[d], d));
  return std::make_shared<Box>(lo, hi);
}

SolidPtr sphere(const Eigen::Vector3d& centre, double radius) {
  check_finite(centre, "a sphere centre");
  if (!(radius > 0.0) || !std::isfinite(radius)) throw std::invalid_argument(fmt::format("geometry: sphere radius {}", radius));
  return std::make_shared<Sphere>(centre, radius);
}

SolidPtr cylinder(const Cylinder& c) {
  check_finite(c.centre, "a cylinder centre");
  check_finite(c.axis, "a cylinder axis");
  if (!(c.axis.norm() > 0.0)) throw std::invalid_argument("geometry: a cylinder axis of zero length");
  if (!(c.radius > 0.0) || !std::isfinite(c.radius)) throw std::invalid_argument(fmt::format("geometry: cylinder radius {}", c.radius));
  if (!std::isfinite(c.half_length)) throw std::invalid_argument("geometry: a cylinder half length is not finite");
  return std::make_shared<CylinderSolid>(c);
}

SolidPtr tube_wall(const Tube& t) {
  check_finite(t.centre, "a tube centre");
  check_finite(t.axis, "a tube axis");
  if (!(t.axis.norm() > 0.0)) throw std::invalid_argument("geometry: a tube axis of zero length");
  for (const double v : {t.far_radius, t.throat_radius, t.half_length})
    if (!(v > 0.0) || !std::isfinite(v))
      throw std::invalid_argument(fmt::format("geometry: tube radii and half length must be > 0 (got {})", v));
  return std::make_shared<TubeWall>(t);
}

SolidPtr unite(std::vector<SolidPtr> parts) {
  check_parts(parts, "a union");
  return std::make_shared<Combination>(std::move(parts), true);
}

SolidPtr intersect(std::vector<SolidPtr> parts) {
  check_parts(parts, "an intersection");
  return std::make_shared<Combination>(std::move(parts), false);
}

SolidPtr subtract(SolidPtr from, std::vector<SolidPtr> removed) {
  check_parts({from}, "a difference");
  check_parts(removed, "a difference");
  std::vector<SolidPtr> parts{std::move(from)};
  for (SolidPtr& r : removed) parts.push_back(complement(std::move(r)));
  return intersect(std::move(parts));
}

SolidPtr moving_wall(SolidPtr s, const WallMotion& m) {
  check_parts({s}, "a moving wall");
  check_finite(m.velocity, "a wall velocity");
  check_finite(m.angular_velocity, "an angular velocity");
  check_finite(m.centre, "a rotation centre");
  return std::make_shared<MovingWall>(std::move(s), m);
}

SolidPtr complement(SolidPtr s) {
  check_parts({s}, "a complement");
  return std::make_shared<Complement>(std::move(s));
}

}  // namespace capsflow::geometry
