#pragma once
// Solid regions inside the brick (issue "Walls of any shape"), as signed distances: phi(x) < 0
// inside the solid, > 0 in the fluid, |phi| the distance to the wall. The primitives give the
// exact distance; unions, intersections and differences (min and max of their parts, as in
// Basilisk's and AMReX's implicit functions) keep the wall exactly where the set operation
// puts it and stay 1-Lipschitz, but away from the wall |phi| is then a lower bound of the
// distance, not the distance. The tree and the operators ask a Solid only through the
// embedded geometry built from it (cell and face fractions, normals), so what a solid is made
// of stays here.
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace capsflow::geometry {

class Solid {
 public:
  virtual ~Solid() = default;
  // < 0 inside the solid, > 0 outside, 0 on its surface.
  [[nodiscard]] virtual double signed_distance(const Eigen::Vector3d& x) const = 0;
  // The velocity of the wall at a point x on it (no slip: the fluid's there): zero unless the
  // wall slides along itself (moving_wall below).
  [[nodiscard]] virtual Eigen::Vector3d wall_velocity(const Eigen::Vector3d&) const { return Eigen::Vector3d::Zero(); }
  [[nodiscard]] virtual bool moves() const { return false; }
};

using SolidPtr = std::shared_ptr<const Solid>;

// The axis-aligned box [lo, hi] (lo < hi on every axis).
[[nodiscard]] SolidPtr box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);
// The ball of this centre and radius (> 0).
[[nodiscard]] SolidPtr sphere(const Eigen::Vector3d& centre, double radius);
// The cylinder of this radius around the line through `centre` along `axis` (any non-zero
// vector). half_length <= 0: infinite. Otherwise it spans half_length either side of the
// centre along the axis, with flat ends, or with rounded ones (hemispheres of the radius
// beyond each end: a capsule shape).
struct Cylinder {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  double radius = 1.0;
  double half_length = 0.0;
  bool rounded_ends = false;
};
[[nodiscard]] SolidPtr cylinder(const Cylinder& c);

// The wall around a circular tube whose radius changes along its axis: `far_radius` beyond
// `half_length` either side of `centre`, `throat_radius` at the centre, and between them a
// cosine blend, R(s) = far + (throat - far) (1 + cos(pi s / half_length)) / 2: a smooth
// constriction (throat < far) or expansion (throat > far). The fluid is inside the tube; the
// distance is exact (the nearest point of a surface of revolution lies in the point's
// meridian plane, where it is found by a 1D minimisation).
struct Tube {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  double far_radius = 1.0;
  double throat_radius = 1.0;
  double half_length = 1.0;
};
[[nodiscard]] SolidPtr tube_wall(const Tube& t);

// A solid whose wall slides along itself while the solid stays in place (a rotating
// cylinder or sphere, a cylinder sliding along its axis): wall velocity
//   v(x) = velocity + angular_velocity x (x - centre).
// The motion must be tangential to the wall everywhere (the caller's to check: the flow keeps
// no flux through walls). Set operations take the wall velocity of the part whose wall is
// nearest the point.
struct WallMotion {
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};
[[nodiscard]] SolidPtr moving_wall(SolidPtr s, const WallMotion& m);

// Set operations on solids (each at least one part).
[[nodiscard]] SolidPtr unite(std::vector<SolidPtr> parts);
[[nodiscard]] SolidPtr intersect(std::vector<SolidPtr> parts);
// What of `from` lies outside every one of `removed`.
[[nodiscard]] SolidPtr subtract(SolidPtr from, std::vector<SolidPtr> removed);
// Everything outside `s` (e.g. the wall around a tube: the complement of a cylinder).
[[nodiscard]] SolidPtr complement(SolidPtr s);

}  // namespace capsflow::geometry
