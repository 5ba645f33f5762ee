// Case file -> CaseConfig. Reading is strict and section by section: each section asks for
// every key it knows (TableReader), reports the first unknown one, and only then looks at
// its sub-tables, so a misspelt section name is reported as such rather than as a missing
// boundary condition further down. Value ranges are checked afterwards by validate_case.
#include <cerrno>
#include <cstring>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <memory>
#include <string>

#include "io/case_config.hpp"
#include "io/case_overrides.hpp"
#include "io/case_validate.hpp"
#include "io/toml_reader.hpp"

namespace capsflow::io {

namespace {

using detail::CaseSource;
using detail::TableReader;

std::string toml_string_of(SolidShape shape) { return detail::toml_string(to_string(shape)); }

void parse_domain(TableReader r, int dim, DomainConfig& d) {
  r.read("roots", d.roots, dim);
  r.read("root_size", d.root_size);
  r.read("origin", d.origin, dim);
  r.read("periodic", d.periodic, dim);
  r.finish();
}

void parse_side(TableReader r, int dim, const std::array<double, 3>& side_centre, BoundaryConfig& b) {
  if (!r.read("type", b.type, detail::kBoundaryTypes))
    r.missing("type", "wall, moving_wall, inflow, outflow or periodic");
  // Keys of another type are reported as such, not as unknown keys.
  auto only_for = [&](std::string_view key, BoundaryType owner) {
    if (b.type != owner && r.has(key))
      r.source().fail(r.key_path(key), detail::toml_repr(*r.node(key)),
                      fmt::format("only used with type = \"{}\" (this side is \"{}\")",
                                  to_string(owner), to_string(b.type)));
  };
  only_for("velocity", BoundaryType::moving_wall);
  only_for("profile", BoundaryType::inflow);
  only_for("mean_velocity", BoundaryType::inflow);
  if (b.type == BoundaryType::moving_wall && !r.read("velocity", b.velocity, dim))
    r.missing("velocity", "a moving wall needs its velocity");
  if (b.type == BoundaryType::inflow) {
    r.read("profile", b.profile, detail::kInflowProfiles);
    r.read("mean_velocity", b.mean_velocity);
    for (const std::string_view key : {"radius", "centre"})
      if (b.profile != InflowProfile::pipe && r.has(key))
        r.source().fail(r.key_path(key), detail::toml_repr(*r.node(key)),
                        fmt::format("only used with profile = \"pipe\" (this side's is \"{}\")", to_string(b.profile)));
    if (b.profile == InflowProfile::pipe) {
      if (!r.read("radius", b.radius)) r.missing("radius", "a pipe profile needs the pipe's radius");
      b.centre = side_centre;
      r.read("centre", b.centre, dim);
    }
  }
  r.finish();
}

void parse_boundary(TableReader r, const DomainConfig& domain, int dim, FluidConfig& f) {
  if (dim == 2)
    for (const std::string_view z : {"z_lo", "z_hi"})
      if (r.has(z)) r.source().fail(r.key_path(z), "there is no z side in a 2D case (dimension = 2)");
  for (int s = 0; s < 2 * dim; ++s) {
    const std::string_view name = detail::kSideNames[s];
    const int d = s / 2;
    if (const toml::table* t = r.table(name)) {
      std::array<double, 3> side_centre{};  // the centre of the side, the pipe profile's default axis
      for (int a = 0; a < dim; ++a) {
        const double extent = domain.roots[static_cast<std::size_t>(a)] * domain.root_size;
        side_centre[static_cast<std::size_t>(a)] =
            domain.origin[static_cast<std::size_t>(a)] + (a == d ? (s & 1) * extent : 0.5 * extent);
      }
      parse_side(TableReader(*t, r.key_path(name), r.source()), dim, side_centre, f.boundary[s]);
    } else if (domain.periodic[d]) {
      f.boundary[s] = {.type = BoundaryType::periodic};
    } else {
      r.missing(name, fmt::format("{} is not periodic, so this side needs a boundary condition, "
                                  "e.g. {} = {{ type = \"wall\" }}",
                                  detail::kAxisNames[d], name));
    }
  }
  r.finish();
}

void parse_fluid(TableReader r, const DomainConfig& domain, int dim, FluidConfig& f) {
  r.read("Re", f.Re);
  r.read("stokes", f.stokes);
  r.read("crank_nicolson", f.crank_nicolson);
  r.read("carry_faces", f.carry_faces);
  r.read("current_force_in_viscous", f.current_force_in_viscous);
  r.read("pressure_iterations", f.pressure_iterations);
  // Moved to each capsule (issue 29): one ratio for the whole flow would not say whose inside.
  for (const std::string_view moved : {"density_ratio", "viscosity_ratio"})
    if (double v = 0.0; r.read(moved, v))
      r.source().fail(r.key_path(moved), detail::toml_number(v),
                      fmt::format("the inner fluid is now given per capsule: set {} in each [[capsule]] table", moved));
  const toml::table* mg = r.table("multigrid");
  const toml::table* bc = r.table("boundary");
  r.finish();
  if (mg) {
    TableReader m(*mg, r.key_path("multigrid"), r.source());
    m.read("tolerance", f.multigrid.tolerance);
    m.read("max_cycles", f.multigrid.max_cycles);
    m.read("fail_on_unconverged", f.multigrid.fail_on_unconverged);
    m.finish();
  }
  const toml::table empty;
  parse_boundary(TableReader(bc ? *bc : empty, r.key_path("boundary"), r.source()), domain, dim, f);
}

void parse_adapt(TableReader r, AdaptConfig& a) {
  r.read("enabled", a.enabled);
  r.read("min_level", a.min_level);
  r.read("max_level", a.max_level);
  r.read("velocity_tolerance", a.velocity_tolerance);
  r.read("velocity_tolerance_relative", a.velocity_tolerance_relative);
  r.read("wall_level", a.wall_level);
  r.read("membrane_band", a.membrane_band);
  r.read("membrane_weight", a.membrane_weight);
  r.read("interval", a.interval);
  r.read("max_interval", a.max_interval);
  r.read("interval_time", a.interval_time);
  r.read("max_interval_time", a.max_interval_time);
  r.finish();
}

CapsuleConfig parse_capsule(TableReader r) {
  CapsuleConfig c;
  r.read("law", c.law, detail::kMembraneLaws);
  r.read("Ca", c.Ca);
  r.read("C", c.C);
  r.read("nodes", c.nodes);
  r.read("element_order", c.element_order);
  if (!r.read("radius", c.radius)) r.missing("radius", "the capsule's stress-free radius");
  if (!r.read("centre", c.centre, 3)) r.missing("centre", "the capsule's centre, [x, y, z]");
  r.read("shape", c.shape, detail::kInitialShapes);
  r.read("axes_factors", c.axes_factors, 3);
  r.read("inflation", c.inflation);
  r.read("spread_kernel", c.spread_kernel, detail::kKernelTypes);
  r.read("interp_kernel", c.interp_kernel, detail::kKernelTypes);
  r.read("staggered", c.staggered);
  r.read("divergence_free", c.divergence_free);
  r.read("viscosity_ratio", c.viscosity_ratio);
  r.read("density_ratio", c.density_ratio);
  r.finish();
  return c;
}

// A [[solid]] table: `shape` first, then the keys of that shape; a key of another shape is
// reported as such. An STL path is taken relative to the case file's folder and kept
// absolute, so the case.toml a run writes elsewhere still finds it.
SolidConfig parse_solid(TableReader r, int dim) {
  SolidConfig s;
  if (!r.read("shape", s.shape, detail::kSolidShapes)) r.missing("shape", "box, sphere, cylinder, tube or stl");
  r.read("combine", s.combine, detail::kSolidCombines);
  r.read("fill", s.fill, detail::kSolidFills);
  using enum SolidShape;
  struct Owned {
    std::string_view key;
    std::initializer_list<SolidShape> shapes;
  };
  static const Owned kOwners[] = {{"lo", {box}},           {"hi", {box}},
                                  {"centre", {sphere, cylinder, tube}}, {"radius", {sphere, cylinder}},
                                  {"axis", {cylinder, tube}}, {"half_length", {cylinder, tube}},
                                  {"rounded_ends", {cylinder}}, {"far_radius", {tube}},
                                  {"throat_radius", {tube}}, {"file", {stl}},
                                  {"scale", {stl}},          {"translate", {stl}},
                                  {"angular_velocity", {sphere, cylinder, tube}}, {"axial_velocity", {cylinder}}};
  for (const Owned& o : kOwners) {
    if (!r.has(o.key) || std::ranges::find(o.shapes, s.shape) != o.shapes.end()) continue;
    std::string names;
    for (const SolidShape owner : o.shapes) names += (names.empty() ? "" : " or ") + toml_string_of(owner);
    r.source().fail(r.key_path(o.key), detail::toml_repr(*r.node(o.key)),
                    fmt::format("only used with shape = {} (this solid is {})", names, toml_string_of(s.shape)));
  }
  auto need = [&r](bool found, std::string_view key, std::string_view why) {
    if (!found) r.missing(key, why);
  };
  switch (s.shape) {
    case box:
      need(r.read("lo", s.lo, dim), "lo", "the box's lower corner");
      need(r.read("hi", s.hi, dim), "hi", "the box's upper corner");
      break;
    case sphere:
      need(r.read("centre", s.centre, dim), "centre", "the sphere's centre");
      need(r.read("radius", s.radius), "radius", "the sphere's radius");
      break;
    case cylinder:
      need(r.read("centre", s.centre, dim), "centre", "a point on the cylinder's axis");
      need(r.read("radius", s.radius), "radius", "the cylinder's radius");
      r.read("axis", s.axis, dim);
      r.read("half_length", s.half_length);
      r.read("rounded_ends", s.rounded_ends);
      break;
    case tube:
      need(r.read("centre", s.centre, dim), "centre", "the centre of the tube's throat");
      need(r.read("far_radius", s.far_radius), "far_radius", "the tube's radius away from the throat");
      need(r.read("throat_radius", s.throat_radius), "throat_radius", "the tube's radius at its throat");
      need(r.read("half_length", s.half_length), "half_length", "the half-length of the change of radius");
      r.read("axis", s.axis, dim);
      break;
    case stl: {
      need(r.read("file", s.file), "file", "the STL file of the surface");
      r.read("scale", s.scale);
      r.read("translate", s.translate, dim);
      std::filesystem::path file(s.file);
      if (!s.file.empty() && file.is_relative()) file = std::filesystem::path(r.source().name).parent_path() / file;
      if (!s.file.empty()) s.file = std::filesystem::absolute(file).lexically_normal().string();
      break;
    }
  }
  if (s.shape == sphere || s.shape == cylinder || s.shape == tube) r.read("angular_velocity", s.angular_velocity, 3);
  if (s.shape == cylinder) r.read("axial_velocity", s.axial_velocity);
  r.finish();
  return s;
}

void parse_time(TableReader r, TimeConfig& t) {
  r.read("dt", t.dt);
  r.read("t_end", t.t_end);
  r.read("cfl", t.cfl);
  r.read("dt_max", t.dt_max);
  r.read("node_scheme", t.node_scheme, detail::kNodeSchemes);
  r.read("coupling", t.coupling, detail::kCouplings);
  r.read("tolerance", t.tolerance);
  r.read("implicit_tolerance", t.implicit_tolerance);
  r.read("implicit_max_iterations", t.implicit_max_iterations);
  r.finish();
}

void parse_output(TableReader r, OutputConfig& o) {
  r.read("interval", o.interval);
  r.read("diagnostics_interval", o.diagnostics_interval);
  r.read("vtu", o.vtu);
  r.read("checkpoint", o.checkpoint);
  r.read("checkpoint_interval", o.checkpoint_interval);
  r.read("cells_csv", o.cells_csv);
  r.read("directory", o.directory);
  r.finish();
}

CaseConfig parse_root(const toml::table& root, CaseSource& source) {
  CaseConfig c;
  TableReader r(root, "", source);
  if (!r.read("name", c.name)) c.name = std::filesystem::path(source.name).stem().string();
  if (r.read("dimension", c.dimension) && c.dimension != 2 && c.dimension != 3)
    source.fail("dimension", fmt::format("{}", c.dimension), "must be 2 or 3");
  const toml::table* domain = r.table("domain");
  const toml::table* fluid = r.table("fluid");
  const toml::table* adapt = r.table("adapt");
  const toml::array* capsules = r.array_of_tables("capsule");
  const toml::array* solids = r.array_of_tables("solid");
  const toml::table* time = r.table("time");
  const toml::table* output = r.table("output");
  r.finish();

  const toml::table empty;
  auto section = [&](const toml::table* t, std::string_view name) {
    return TableReader(t ? *t : empty, std::string(name), source);
  };
  parse_domain(section(domain, "domain"), c.dimension, c.domain);
  parse_fluid(section(fluid, "fluid"), c.domain, c.dimension, c.fluid);
  parse_adapt(section(adapt, "adapt"), c.adapt);
  if (capsules)
    for (std::size_t i = 0; i < capsules->size(); ++i)
      c.capsules.push_back(parse_capsule(
          TableReader(*capsules->get(i)->as_table(), fmt::format("capsule[{}]", i), source)));
  if (solids)
    for (std::size_t i = 0; i < solids->size(); ++i)
      c.solids.push_back(parse_solid(TableReader(*solids->get(i)->as_table(), fmt::format("solid[{}]", i), source),
                                     c.dimension));
  parse_time(section(time, "time"), c.time);
  parse_output(section(output, "output"), c.output);
  if (c.output.directory.empty()) c.output.directory = "out/" + c.name;
  return c;
}

}  // namespace

CaseConfig parse_case_text(std::string_view text, std::string_view source_name,
                           std::span<const std::string> overrides) {
  CaseSource source{.name = std::string(source_name)};
  toml::table root;
  try {
    root = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    source.fail_file(fmt::format("line {}, column {}: syntax error: {}", e.source().begin.line,
                                 e.source().begin.column, e.description()));
  }
  detail::apply_overrides(root, overrides, source);
  CaseConfig config = parse_root(root, source);
  detail::validate_case(config, source);
  return config;
}

CaseConfig parse_case(const std::filesystem::path& path, std::span<const std::string> overrides) {
  const CaseSource source{.name = path.string()};
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) source.fail_file("cannot read the case file: it is a directory");
  // stdio rather than a stream: a stream's buffer turns a read error (EIO from
  // /proc/self/mem, a failing disk) into an end of file, and the case into an empty one.
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> in(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!in) source.fail_file(fmt::format("cannot read the case file: {}", std::strerror(errno)));
  std::string text;
  char buffer[1 << 16];
  std::size_t got = 0;
  while ((got = std::fread(buffer, 1, sizeof buffer, in.get())) > 0) text.append(buffer, got);
  if (std::ferror(in.get())) source.fail_file(fmt::format("cannot read the case file: {}", std::strerror(errno)));
  return parse_case_text(text, path.string(), overrides);
}

}  // namespace capsflow::io
