// [[solid]] tables: value rules and the combined solid (case_solids.hpp).
#include "io/case_solids.hpp"

#include <cmath>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>

#include "geometry/triangle_surface.hpp"
#include "io/case_names.hpp"
#include "io/case_source.hpp"
#include "io/stl_read.hpp"

namespace capsflow::io {

namespace detail {

void check_solid(const CaseConfig& c, std::size_t i, const CaseSource& source) {
  const SolidConfig& s = c.solids[i];
  const std::string key = fmt::format("solid[{}]", i);
  const int dim = c.dimension;
  auto finite = [&](const std::string& k, double v) {
    if (!std::isfinite(v)) source.fail(k, toml_number(v), "must be finite");
  };
  auto positive = [&](const std::string& k, double v) {
    if (!(v > 0.0) || !std::isfinite(v)) source.fail(k, toml_number(v), "must be > 0");
  };
  auto vector = [&](const std::string& name, const std::array<double, 3>& v) {
    for (int d = 0; d < dim; ++d) finite(fmt::format("{}.{}[{}]", key, name, d), v[d]);
  };
  if (i == 0 && s.combine != SolidCombine::unite)
    source.fail(key + ".combine", toml_string(to_string(s.combine)),
                "the first solid has nothing to combine with: it must be \"union\" (the default)");
  auto nonzero_axis = [&] {
    vector("axis", s.axis);
    double length = 0.0;
    for (int d = 0; d < dim; ++d) length += s.axis[d] * s.axis[d];
    if (!(length > 0.0)) source.fail(key + ".axis", "must not be zero");
  };
  // A moving wall slides along itself: a turn about the shape's own axis (any axis through a
  // sphere's centre), a slide along an infinite cylinder's axis; in 2D, a turn in the plane.
  for (int d = 0; d < 3; ++d) finite(fmt::format("{}.angular_velocity[{}]", key, d), s.angular_velocity[d]);
  finite(key + ".axial_velocity", s.axial_velocity);
  const std::string omega = toml_vector(s.angular_velocity, 3);
  if (dim == 2 && (s.angular_velocity[0] != 0.0 || s.angular_velocity[1] != 0.0))
    source.fail(key + ".angular_velocity", omega, "a 2D case turns in its plane: only the z component may be nonzero");
  if (s.shape == SolidShape::cylinder || s.shape == SolidShape::tube) {
    const Eigen::Vector3d w(s.angular_velocity[0], s.angular_velocity[1], s.angular_velocity[2]);
    const Eigen::Vector3d a(s.axis[0], s.axis[1], dim == 3 ? s.axis[2] : 0.0);
    if (a.norm() > 0.0 && w.cross(a.normalized()).norm() > 1e-12 * w.norm())
      source.fail(key + ".angular_velocity", omega,
                  "must be parallel to the axis (the wall turns about it, sliding along itself)");
  }
  if (s.axial_velocity != 0.0 && s.half_length != 0.0)
    source.fail(key + ".axial_velocity", toml_number(s.axial_velocity),
                "only an infinite cylinder (half_length = 0) slides along itself");
  switch (s.shape) {
    case SolidShape::box:
      vector("lo", s.lo);
      vector("hi", s.hi);
      for (int d = 0; d < dim; ++d)
        if (!(s.lo[d] < s.hi[d]))
          source.fail(fmt::format("{}.hi[{}]", key, d), toml_number(s.hi[d]),
                      fmt::format("must be > lo[{}] = {}", d, toml_number(s.lo[d])));
      break;
    case SolidShape::sphere:
      vector("centre", s.centre);
      positive(key + ".radius", s.radius);
      break;
    case SolidShape::cylinder:
      vector("centre", s.centre);
      positive(key + ".radius", s.radius);
      nonzero_axis();
      if (!(s.half_length >= 0.0) || !std::isfinite(s.half_length))
        source.fail(key + ".half_length", toml_number(s.half_length), "must be >= 0 (0: an infinite cylinder)");
      if (s.rounded_ends && s.half_length == 0.0)
        source.fail(key + ".rounded_ends", "true", "an infinite cylinder (half_length = 0) has no ends");
      break;
    case SolidShape::tube:
      vector("centre", s.centre);
      positive(key + ".far_radius", s.far_radius);
      positive(key + ".throat_radius", s.throat_radius);
      positive(key + ".half_length", s.half_length);
      nonzero_axis();
      break;
    case SolidShape::stl:
      if (dim != 3) source.fail(key + ".shape", "\"stl\"", "STL surfaces need dimension = 3");
      if (s.file.empty()) source.fail(key + ".file", "\"\"", "must name an STL file");
      positive(key + ".scale", s.scale);
      vector("translate", s.translate);
      break;
  }
}

}  // namespace detail

namespace {

Eigen::Vector3d point(const std::array<double, 3>& v) { return {v[0], v[1], v[2]}; }

// A 2D case sees the section z = 0 of its solids: a box there spans far along z, so that its
// section is the rectangle lo-hi (its |phi| stays a lower bound of the distance).
constexpr double kFlatBoxDepth = 1e6;

geometry::SolidPtr make_shape(const SolidConfig& s, int dim) {
  switch (s.shape) {
    case SolidShape::box: {
      Eigen::Vector3d lo = point(s.lo), hi = point(s.hi);
      if (dim == 2) {
        lo[2] = -kFlatBoxDepth;
        hi[2] = kFlatBoxDepth;
      }
      return geometry::box(lo, hi);
    }
    case SolidShape::sphere: return geometry::sphere(point(s.centre), s.radius);
    case SolidShape::cylinder:
      return geometry::cylinder({.centre = point(s.centre), .axis = point(s.axis), .radius = s.radius,
                                 .half_length = s.half_length, .rounded_ends = s.rounded_ends});
    case SolidShape::tube:
      return geometry::tube_wall({.centre = point(s.centre), .axis = point(s.axis), .far_radius = s.far_radius,
                                  .throat_radius = s.throat_radius, .half_length = s.half_length});
    case SolidShape::stl: {
      geometry::TriangleMesh mesh = read_stl(s.file);  // a CaseError naming the file
      for (Eigen::Index k = 0; k < mesh.vertices.cols(); ++k)
        mesh.vertices.col(k) = s.scale * mesh.vertices.col(k) + point(s.translate);
      try {
        return geometry::triangle_surface(std::move(mesh));
      } catch (const std::invalid_argument& e) {
        throw CaseError(fmt::format("{}: {}", s.file, e.what()));
      }
    }
  }
  throw std::logic_error("make_shape: unknown shape");
}

}  // namespace

geometry::SolidPtr make_solid(const CaseConfig& config, std::string_view source) {
  geometry::SolidPtr solid;
  for (std::size_t i = 0; i < config.solids.size(); ++i) {
    const SolidConfig& s = config.solids[i];
    geometry::SolidPtr shape;
    try {
      shape = make_shape(s, config.dimension);
    } catch (const std::exception& e) {  // an STL file's CaseError (it names the file), a refused shape
      const std::string key = fmt::format("solid[{}]{}", i, s.shape == SolidShape::stl ? ".file" : "");
      throw CaseError(detail::one_line(fmt::format("{}: {}: {}", source, key, e.what())));
    }
    const Eigen::Vector3d omega = point(s.angular_velocity);
    if (omega.norm() > 0.0 || s.axial_velocity != 0.0) {
      Eigen::Vector3d axis = point(s.axis);
      if (config.dimension == 2) axis[2] = 0.0;
      const Eigen::Vector3d slide = s.axial_velocity != 0.0 ? Eigen::Vector3d(s.axial_velocity * axis.normalized())
                                                            : Eigen::Vector3d::Zero();
      shape = geometry::moving_wall(std::move(shape),
                                    {.velocity = slide, .angular_velocity = omega, .centre = point(s.centre)});
    }
    if (s.fill == SolidFill::outside) shape = geometry::complement(std::move(shape));
    if (!solid) {
      solid = std::move(shape);
      continue;
    }
    switch (s.combine) {
      case SolidCombine::unite: solid = geometry::unite({solid, shape}); break;
      case SolidCombine::subtract: solid = geometry::subtract(solid, {shape}); break;
      case SolidCombine::intersect: solid = geometry::intersect({solid, shape}); break;
    }
  }
  return solid;
}

}  // namespace capsflow::io
