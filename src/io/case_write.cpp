// CaseConfig -> TOML, every key written (defaults included), in the order of
// docs/case-file.md. Doubles use the shortest digits that read back to the same value, so
// parse_case_text(to_toml(c)) == c; this is the case.toml a run leaves for reproducibility.
#include <fmt/format.h>

#include "io/case_config.hpp"
#include "io/case_names.hpp"
#include "io/case_source.hpp"

namespace capsflow::io {

namespace {

using detail::toml_string;
using detail::toml_number;

template <class T>
std::string array_repr(const std::array<T, 3>& v, int n) {
  std::string s = "[";
  for (int i = 0; i < n; ++i) {
    if (i) s += ", ";
    if constexpr (std::is_same_v<T, double>) s += toml_number(v[i]);
    else if constexpr (std::is_same_v<T, bool>) s += v[i] ? "true" : "false";
    else s += fmt::format("{}", v[i]);
  }
  return s + "]";
}

std::string_view b(bool v) { return v ? "true" : "false"; }

std::string side_repr(const BoundaryConfig& s, int dim) {
  switch (s.type) {
    case BoundaryType::moving_wall:
      return fmt::format("{{ type = \"moving_wall\", velocity = {} }}", array_repr(s.velocity, dim));
    case BoundaryType::inflow:
      if (s.profile == InflowProfile::pipe)
        return fmt::format("{{ type = \"inflow\", profile = \"pipe\", mean_velocity = {}, radius = {}, centre = {} }}",
                           toml_number(s.mean_velocity), toml_number(s.radius), array_repr(s.centre, dim));
      return fmt::format("{{ type = \"inflow\", profile = {}, mean_velocity = {} }}",
                         toml_string(to_string(s.profile)), toml_number(s.mean_velocity));
    default: return fmt::format("{{ type = {} }}", toml_string(to_string(s.type)));
  }
}

}  // namespace

std::string to_toml(const CaseConfig& c) {
  const int n = c.dimension;
  std::string out;
  auto line = [&](std::string_view key, std::string_view value) {
    out += fmt::format("{} = {}\n", key, value);
  };
  out += "# capsflow case, every key written out (docs/case-file.md)\n";
  line("name", toml_string(c.name));
  line("dimension", fmt::format("{}", n));

  out += "\n[domain]\n";
  line("roots", array_repr(c.domain.roots, n));
  line("root_size", toml_number(c.domain.root_size));
  line("origin", array_repr(c.domain.origin, n));
  line("periodic", array_repr(c.domain.periodic, n));

  out += "\n[fluid]\n";
  line("Re", toml_number(c.fluid.Re));
  line("stokes", b(c.fluid.stokes));
  line("crank_nicolson", b(c.fluid.crank_nicolson));
  line("carry_faces", b(c.fluid.carry_faces));
  line("current_force_in_viscous", b(c.fluid.current_force_in_viscous));
  line("pressure_iterations", fmt::format("{}", c.fluid.pressure_iterations));
  out += "\n[fluid.multigrid]\n";
  line("tolerance", toml_number(c.fluid.multigrid.tolerance));
  line("max_cycles", fmt::format("{}", c.fluid.multigrid.max_cycles));
  line("fail_on_unconverged", b(c.fluid.multigrid.fail_on_unconverged));
  out += "\n[fluid.boundary]\n";
  for (int s = 0; s < 2 * n; ++s) line(detail::kSideNames[s], side_repr(c.fluid.boundary[s], n));

  out += "\n[adapt]\n";
  line("enabled", b(c.adapt.enabled));
  line("min_level", fmt::format("{}", c.adapt.min_level));
  line("max_level", fmt::format("{}", c.adapt.max_level));
  line("velocity_tolerance", toml_number(c.adapt.velocity_tolerance));
  line("velocity_tolerance_relative", toml_number(c.adapt.velocity_tolerance_relative));
  line("wall_level", fmt::format("{}", c.adapt.wall_level));
  line("membrane_band", fmt::format("{}", c.adapt.membrane_band));
  line("membrane_weight", fmt::format("{}", c.adapt.membrane_weight));
  line("interval", fmt::format("{}", c.adapt.interval));
  line("max_interval", fmt::format("{}", c.adapt.max_interval));
  line("interval_time", toml_number(c.adapt.interval_time));
  line("max_interval_time", toml_number(c.adapt.max_interval_time));

  for (const CapsuleConfig& cap : c.capsules) {
    out += "\n[[capsule]]\n";
    line("law", toml_string(to_string(cap.law)));
    line("Ca", toml_number(cap.Ca));
    line("C", toml_number(cap.C));
    line("nodes", fmt::format("{}", cap.nodes));
    line("element_order", fmt::format("{}", cap.element_order));
    line("radius", toml_number(cap.radius));
    line("centre", array_repr(cap.centre, 3));
    line("shape", toml_string(to_string(cap.shape)));
    line("axes_factors", array_repr(cap.axes_factors, 3));
    line("inflation", toml_number(cap.inflation));
    line("spread_kernel", toml_string(to_string(cap.spread_kernel)));
    line("interp_kernel", toml_string(to_string(cap.interp_kernel)));
    line("staggered", b(cap.staggered));
    line("divergence_free", b(cap.divergence_free));
    line("viscosity_ratio", toml_number(cap.viscosity_ratio));
    line("density_ratio", toml_number(cap.density_ratio));
  }

  for (const SolidConfig& s : c.solids) {
    out += "\n[[solid]]\n";
    line("shape", toml_string(to_string(s.shape)));
    line("combine", toml_string(to_string(s.combine)));
    line("fill", toml_string(to_string(s.fill)));
    switch (s.shape) {  // the keys of this shape only: the others are refused on reading
      case SolidShape::box:
        line("lo", array_repr(s.lo, n));
        line("hi", array_repr(s.hi, n));
        break;
      case SolidShape::sphere:
        line("centre", array_repr(s.centre, n));
        line("radius", toml_number(s.radius));
        line("angular_velocity", array_repr(s.angular_velocity, 3));
        break;
      case SolidShape::cylinder:
        line("centre", array_repr(s.centre, n));
        line("radius", toml_number(s.radius));
        line("axis", array_repr(s.axis, n));
        line("half_length", toml_number(s.half_length));
        line("rounded_ends", b(s.rounded_ends));
        line("angular_velocity", array_repr(s.angular_velocity, 3));
        line("axial_velocity", toml_number(s.axial_velocity));
        break;
      case SolidShape::tube:
        line("centre", array_repr(s.centre, n));
        line("far_radius", toml_number(s.far_radius));
        line("throat_radius", toml_number(s.throat_radius));
        line("half_length", toml_number(s.half_length));
        line("axis", array_repr(s.axis, n));
        line("angular_velocity", array_repr(s.angular_velocity, 3));
        break;
      case SolidShape::stl:
        line("file", toml_string(s.file));
        line("scale", toml_number(s.scale));
        line("translate", array_repr(s.translate, n));
        break;
    }
  }

  out += "\n[time]\n";
  line("dt", toml_number(c.time.dt));
  line("t_end", toml_number(c.time.t_end));
  line("cfl", toml_number(c.time.cfl));
  line("dt_max", toml_number(c.time.dt_max));
  line("node_scheme", toml_string(to_string(c.time.node_scheme)));
  line("coupling", toml_string(to_string(c.time.coupling)));
  line("tolerance", toml_number(c.time.tolerance));
  line("implicit_tolerance", toml_number(c.time.implicit_tolerance));
  line("implicit_max_iterations", fmt::format("{}", c.time.implicit_max_iterations));

  out += "\n[output]\n";
  line("interval", fmt::format("{}", c.output.interval));
  line("diagnostics_interval", fmt::format("{}", c.output.diagnostics_interval));
  line("vtu", b(c.output.vtu));
  line("checkpoint", b(c.output.checkpoint));
  line("checkpoint_interval", fmt::format("{}", c.output.checkpoint_interval));
  line("cells_csv", b(c.output.cells_csv));
  line("directory", toml_string(c.output.directory));
  return out;
}

}  // namespace capsflow::io
