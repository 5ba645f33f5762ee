// The value rules of a case file (docs/case-file.md, "Rules"). Each failure names the
// dotted key, its value and the rule, in one line.
#include "io/case_validate.hpp"

#include <algorithm>
#include <cmath>

#include "ibm/kernels.hpp"
#include "io/case_names.hpp"
#include "io/case_solids.hpp"

namespace capsflow::io {

namespace detail {

namespace {

class Checker {
 public:
  explicit Checker(const CaseSource& source) : source_(source) {}

  void positive(const std::string& key, double v) const {
    if (!(v > 0.0) || !std::isfinite(v)) source_.fail(key, toml_number(v), "must be > 0");
  }
  void non_negative(const std::string& key, double v) const {
    if (!(v >= 0.0) || !std::isfinite(v)) source_.fail(key, toml_number(v), "must be >= 0");
  }
  void finite(const std::string& key, double v) const {
    if (!std::isfinite(v)) source_.fail(key, toml_number(v), "must be finite");
  }
  void at_least(const std::string& key, int v, int min) const {
    if (v < min) source_.fail(key, fmt::format("{}", v), fmt::format("must be >= {}", min));
  }
  [[noreturn]] void fail(const std::string& key, const std::string& value, const std::string& why) const {
    source_.fail(key, value, why);
  }
  [[noreturn]] void fail(const std::string& key, const std::string& why) const { source_.fail(key, why); }

 private:
  const CaseSource& source_;
};

// Lengths are in units of the channel half-width l: a brick of 1e9 l or a root of 1e-9 l is
// a unit mistake, and beyond such magnitudes cell sizes and positions (root_size / 2^level,
// origin + i h) lose their digits or overflow.
constexpr double kMaxLength = 1e9;
constexpr double kMinRootSize = 1e-9;

void check_domain(const CaseConfig& c, const Checker& ck) {
  for (int d = 0; d < c.dimension; ++d) ck.at_least(fmt::format("domain.roots[{}]", d), c.domain.roots[d], 1);
  ck.positive("domain.root_size", c.domain.root_size);
  if (c.domain.root_size > kMaxLength || c.domain.root_size < kMinRootSize)
    ck.fail("domain.root_size", toml_number(c.domain.root_size),
            fmt::format("must be in [{:g}, {:g}]: lengths are in units of the channel half-width, and beyond "
                        "that range the cell sizes and positions overflow or lose their digits",
                        kMinRootSize, kMaxLength));
  for (int d = 0; d < c.dimension; ++d) {
    const std::string key = fmt::format("domain.origin[{}]", d);
    ck.finite(key, c.domain.origin[d]);
    if (std::abs(c.domain.origin[d]) > kMaxLength)
      ck.fail(key, toml_number(c.domain.origin[d]),
              fmt::format("|origin| must be <= {:g}: lengths are in units of the channel half-width", kMaxLength));
  }
}

// Periodicity is a property of a direction: both sides periodic, and only when
// domain.periodic says so; non-periodic sides carry a physical condition.
void check_boundary(const CaseConfig& c, const Checker& ck) {
  const int dim = c.dimension;
  for (int s = 0; s < 2 * dim; ++s) {
    const int d = s / 2;
    const BoundaryConfig& b = c.fluid.boundary[s];
    const BoundaryConfig& facing = c.fluid.boundary[s ^ 1];
    const std::string key = fmt::format("fluid.boundary.{}", kSideNames[s]);
    const std::string type = toml_string(to_string(b.type));
    if (c.domain.periodic[d] && b.type != BoundaryType::periodic)
      ck.fail(key + ".type", type,
              fmt::format("{} is periodic (domain.periodic), so this side must be \"periodic\" or left out",
                          kAxisNames[d]));
    if (!c.domain.periodic[d] && b.type == BoundaryType::periodic) {
      if (facing.type != BoundaryType::periodic)
        ck.fail(key + ".type", type,
                fmt::format("a periodic side cannot face a non-periodic one ({} is \"{}\")",
                            kSideNames[s ^ 1], to_string(facing.type)));
      ck.fail(key + ".type", type,
              fmt::format("domain.periodic is false along {}; set it to true for a periodic direction",
                          kAxisNames[d]));
    }
    if (b.type == BoundaryType::moving_wall) {
      for (int i = 0; i < dim; ++i) ck.finite(fmt::format("{}.velocity[{}]", key, i), b.velocity[i]);
      if (b.velocity[d] != 0.0)
        ck.fail(key + ".velocity", toml_vector(b.velocity, dim),
                fmt::format("the normal component ({}) must be 0: a wall slides along itself",
                            kAxisNames[d]));
    }
    if (b.type == BoundaryType::inflow) {
      ck.positive(key + ".mean_velocity", b.mean_velocity);
      if ((b.profile == InflowProfile::square_duct || b.profile == InflowProfile::pipe) && dim != 3)
        ck.fail(key + ".profile", toml_string(to_string(b.profile)),
                fmt::format("the {} profile needs dimension = 3 (use \"parabolic\" in 2D)", to_string(b.profile)));
      if (b.profile == InflowProfile::pipe) {
        ck.positive(key + ".radius", b.radius);
        for (int i = 0; i < dim; ++i) ck.finite(fmt::format("{}.centre[{}]", key, i), b.centre[i]);
      }
    }
  }
}

void check_fluid(const CaseConfig& c, const Checker& ck) {
  ck.positive("fluid.Re", c.fluid.Re);
  ck.positive("fluid.multigrid.tolerance", c.fluid.multigrid.tolerance);
  ck.at_least("fluid.multigrid.max_cycles", c.fluid.multigrid.max_cycles, 1);
  check_boundary(c, ck);
}

void check_adapt(const CaseConfig& c, const Checker& ck) {
  const AdaptConfig& a = c.adapt;
  ck.at_least("adapt.min_level", a.min_level, 0);
  if (a.max_level < a.min_level)
    ck.fail("adapt.max_level", fmt::format("{}", a.max_level),
            fmt::format("must be >= adapt.min_level ({})", a.min_level));
  const int limit = max_tree_level(c);
  if (a.max_level > limit)
    ck.fail("adapt.max_level", fmt::format("{}", a.max_level),
            fmt::format("above {}, the deepest level the tree allows on these roots (Morton key limit)",
                        limit));
  ck.positive("adapt.velocity_tolerance", a.velocity_tolerance);
  ck.non_negative("adapt.velocity_tolerance_relative", a.velocity_tolerance_relative);
  ck.at_least("adapt.wall_level", a.wall_level, 0);
  if (a.wall_level > a.max_level)
    ck.fail("adapt.wall_level", fmt::format("{}", a.wall_level),
            fmt::format("must be <= adapt.max_level ({})", a.max_level));
  ck.at_least("adapt.membrane_band", a.membrane_band, 0);
  ck.at_least("adapt.membrane_weight", a.membrane_weight, 1);
  ck.at_least("adapt.interval", a.interval, 1);
  if (a.max_interval != 0 && a.max_interval < a.interval)
    ck.fail("adapt.max_interval", fmt::format("{}", a.max_interval),
            fmt::format("must be 0 (off) or >= adapt.interval ({})", a.interval));
  ck.non_negative("adapt.interval_time", a.interval_time);
  ck.non_negative("adapt.max_interval_time", a.max_interval_time);
  if (a.interval_time > 0.0 && (a.interval != 1 || a.max_interval != 0))
    ck.fail("adapt.interval_time", toml_number(a.interval_time),
            "replaces adapt.interval and adapt.max_interval: give the interval in steps or in time, not both");
  if (a.max_interval_time != 0.0 && a.max_interval_time < a.interval_time)
    ck.fail("adapt.max_interval_time", toml_number(a.max_interval_time),
            fmt::format("must be 0 (off) or >= adapt.interval_time ({})", toml_number(a.interval_time)));
  if (a.max_interval_time > 0.0 && a.interval_time == 0.0)
    ck.fail("adapt.max_interval_time", toml_number(a.max_interval_time), "needs adapt.interval_time > 0");
}

// The capsule's initial half-extent along direction d (the ellipsoid's axes are the
// coordinate axes, scaled by axes_factors).
double semi_axis(const CapsuleConfig& cap, int d) {
  switch (cap.shape) {
    case InitialShape::ellipsoid: return cap.radius * cap.axes_factors[d];
    case InitialShape::inflated: return cap.radius * cap.inflation;
    case InitialShape::sphere: break;
  }
  return cap.radius;
}

// The radius of a sphere around the capsule's initial shape (its largest semi-axis).
double bounding_radius(const CapsuleConfig& cap) {
  return std::max({semi_axis(cap, 0), semi_axis(cap, 1), semi_axis(cap, 2)});
}

int kernel_support(KernelType k) {
  switch (k) {
    case KernelType::cosine: return ibm::support_of(ibm::KernelKind::cosine);
    case KernelType::hat: return ibm::support_of(ibm::KernelKind::hat);
    case KernelType::peskin4: return ibm::support_of(ibm::KernelKind::peskin4);
  }
  return 0;  // unreachable: the switch is exhaustive (-Wswitch)
}

// How far beyond a node its stencils reach (ibm/stencil.hpp): a kernel of support W uses the
// max-level cells whose centres lie within W/2 cells of it, so the outermost cell's far edge
// is (W - 1)/2 cells of size h away; staggered, the faces within W/2 cells, and a face on
// the upper side is held by the cell above it, up to W/2 cells away (divergence-free: the
// stencil is W + 2 wide, ibm/stencil.hpp). A node closer than
// that to a non-periodic side would need cells outside the domain at the first step.
double kernel_reach(const CaseConfig& c, const CapsuleConfig& cap) {
  const int w = std::max(kernel_support(cap.spread_kernel), kernel_support(cap.interp_kernel)) +
                (cap.staggered && cap.divergence_free ? 2 : 0);
  const double h = c.domain.root_size / static_cast<double>(std::int64_t{1} << c.adapt.max_level);
  return 0.5 * (cap.staggered ? w : w - 1) * h;
}

void check_capsule(const CaseConfig& c, std::size_t i, const Checker& ck) {
  const CapsuleConfig& cap = c.capsules[i];
  const std::string key = fmt::format("capsule[{}]", i);
  if (c.dimension != 3) ck.fail(key, "capsules need dimension = 3");
  ck.positive(key + ".Ca", cap.Ca);
  // C is kept (and written back) whatever the law: a NaN would not read back as itself.
  ck.finite(key + ".C", cap.C);
  if (cap.law == MembraneLaw::skalak && !(cap.C > -0.5 && std::isfinite(cap.C)))
    ck.fail(key + ".C", toml_number(cap.C), "must be > -0.5 (area modulus Gs (1 + 2C) > 0)");
  constexpr std::array kNodes{642, 2562, 10242, 40962};
  if (std::find(kNodes.begin(), kNodes.end(), cap.nodes) == kNodes.end())
    ck.fail(key + ".nodes", fmt::format("{}", cap.nodes), "must be 642, 2562, 10242 or 40962 (icosphere)");
  if (cap.element_order != 1 && cap.element_order != 2)
    ck.fail(key + ".element_order", fmt::format("{}", cap.element_order), "must be 1 (P1) or 2 (P2)");
  ck.positive(key + ".radius", cap.radius);
  if (cap.radius > kMaxLength)
    ck.fail(key + ".radius", toml_number(cap.radius),
            fmt::format("must be <= {:g}: lengths are in units of the channel half-width", kMaxLength));
  for (int d = 0; d < 3; ++d) {
    ck.finite(fmt::format("{}.centre[{}]", key, d), cap.centre[d]);
    ck.positive(fmt::format("{}.axes_factors[{}]", key, d), cap.axes_factors[d]);
  }
  ck.positive(key + ".inflation", cap.inflation);
  ck.positive(key + ".viscosity_ratio", cap.viscosity_ratio);
  ck.positive(key + ".density_ratio", cap.density_ratio);
  for (int d = 0; d < 3; ++d) {
    const double semi = semi_axis(cap, d);
    const double lo = c.domain.origin[d];
    const double hi = lo + c.domain.roots[d] * c.domain.root_size;
    if (cap.centre[d] - semi < lo || cap.centre[d] + semi > hi)
      ck.fail(key + ".centre", toml_vector(cap.centre, 3),
              fmt::format("the capsule does not fit inside the domain: along {} its centre +- {} "
                          "(its initial semi-axis) leaves [{}, {}]",
                          kAxisNames[d], semi, lo, hi));
  }
  const double reach = kernel_reach(c, cap);
  for (int d = 0; d < 3; ++d) {
    if (c.domain.periodic[d]) continue;
    const double semi = semi_axis(cap, d);
    const double lo = c.domain.origin[d];
    const double hi = lo + c.domain.roots[d] * c.domain.root_size;
    const double gap = std::min(cap.centre[d] - semi - lo, hi - cap.centre[d] - semi);
    if (gap < reach)
      ck.fail(key + ".centre", toml_vector(cap.centre, 3),
              fmt::format("the capsule is {:.4g} from a side along {}, within its kernels' reach ({:.4g}: "
                          "(support - 1)/2 cells of the max level, {:.4g}); its stencils would leave the domain",
                          gap, kAxisNames[d], reach,
                          c.domain.root_size / static_cast<double>(std::int64_t{1} << c.adapt.max_level)));
  }
}

// Capsules may not start inside one another: the spheres around their initial shapes must
// be disjoint (a conservative test; the membranes never cross in the flow either).
void check_capsule_overlaps(const CaseConfig& c, const Checker& ck) {
  for (std::size_t j = 1; j < c.capsules.size(); ++j)
    for (std::size_t i = 0; i < j; ++i) {
      const CapsuleConfig& a = c.capsules[i];
      const CapsuleConfig& b = c.capsules[j];
      double dist2 = 0.0;
      for (int d = 0; d < 3; ++d) dist2 += (a.centre[d] - b.centre[d]) * (a.centre[d] - b.centre[d]);
      const double dist = std::sqrt(dist2), reach = bounding_radius(a) + bounding_radius(b);
      if (dist < reach)
        ck.fail(fmt::format("capsule[{}].centre", j), toml_vector(b.centre, 3),
                fmt::format("overlaps capsule[{}]: the centres are {:.4g} apart, less than the sum of the "
                            "capsules' largest initial semi-axes ({:.4g})",
                            i, dist, reach));
    }
}

// More steps than any run can take: the step is a typo or a unit error (5e-324 is a
// denormal; t_end / dt would also overflow the step counter's useful range).
constexpr double kMaxSteps = 1e9;

void check_time(const CaseConfig& c, const Checker& ck) {
  ck.positive("time.dt", c.time.dt);
  ck.positive("time.t_end", c.time.t_end);
  ck.non_negative("time.cfl", c.time.cfl);
  ck.non_negative("time.dt_max", c.time.dt_max);
  const auto steps = [&](const char* key, double dt) {
    const double n = c.time.t_end / dt;
    if (!(n <= kMaxSteps))
      ck.fail(key, toml_number(dt),
              fmt::format("time.t_end / {} = {:.3g} steps, more than {:.0e}: too small a step to be meant "
                          "(a typo or a unit error?)",
                          key, n, kMaxSteps));
  };
  steps("time.dt", c.time.dt);
  if (c.time.dt_max > 0.0) steps("time.dt_max", c.time.dt_max);
  if (!(c.time.implicit_tolerance > 0.0 && c.time.implicit_tolerance < 1.0))
    ck.fail("time.implicit_tolerance", toml_number(c.time.implicit_tolerance), "must lie in (0, 1)");
  ck.at_least("time.implicit_max_iterations", c.time.implicit_max_iterations, 1);
  ck.non_negative("time.tolerance", c.time.tolerance);
  if (c.time.tolerance > 0.0 && c.capsules.empty())
    ck.fail("time.tolerance", toml_number(c.time.tolerance),
            "bounds the membrane nodes' error, and the case has no [[capsule]]: set time.cfl for the flow's step");
  const bool implicit_rule = c.time.node_scheme == NodeScheme::euler || c.time.node_scheme == NodeScheme::bdf2;
  if (c.time.coupling != Coupling::explicit_forces && !implicit_rule)
    ck.fail("time.node_scheme", toml_string(to_string(c.time.node_scheme)),
            "the implicit coupling (time.coupling = \"implicit\" or \"auto\") moves the nodes by Euler's or BDF2's "
            "rule: set time.node_scheme = \"euler\" or \"bdf2\"");
  if (c.time.node_scheme == NodeScheme::bdf2 && (c.fluid.carry_faces || c.fluid.crank_nicolson))
    ck.fail("time.node_scheme", toml_string(to_string(c.time.node_scheme)),
            "BDF2 steps the flow by BDF2 too, with neither fluid.carry_faces nor fluid.crank_nicolson: set them "
            "to false");
  ck.at_least("fluid.pressure_iterations", c.fluid.pressure_iterations, 0);
  if (c.fluid.pressure_iterations > 0 && c.time.node_scheme != NodeScheme::bdf2)
    ck.fail("fluid.pressure_iterations", fmt::format("{}", c.fluid.pressure_iterations),
            "iterates the pressure of BDF2's steps: set time.node_scheme = \"bdf2\" (with time.coupling = "
            "\"implicit\" or \"auto\"), or 0");
  if (c.time.coupling == Coupling::explicit_forces && c.time.node_scheme == NodeScheme::bdf2)
    ck.fail("time.node_scheme", toml_string(to_string(c.time.node_scheme)),
            "BDF2's rule runs with time.coupling = \"auto\" (its steps within the limit of BDF2's explicit "
            "steps stay explicit) or \"implicit\"");
}

void check_output(const CaseConfig& c, const Checker& ck) {
  ck.at_least("output.interval", c.output.interval, 1);
  ck.at_least("output.diagnostics_interval", c.output.diagnostics_interval, 1);
  ck.at_least("output.checkpoint_interval", c.output.checkpoint_interval, 0);
  if (c.output.directory.empty()) ck.fail("output.directory", "\"\"", "must not be empty");
}

}  // namespace

void validate_case(const CaseConfig& c, const CaseSource& source) {
  const Checker ck(source);
  if (c.name.empty()) ck.fail("name", "\"\"", "must not be empty");
  if (c.dimension != 2 && c.dimension != 3)
    ck.fail("dimension", fmt::format("{}", c.dimension), "must be 2 or 3");
  check_domain(c, ck);
  check_fluid(c, ck);
  check_adapt(c, ck);
  for (std::size_t i = 0; i < c.capsules.size(); ++i) check_capsule(c, i, ck);
  check_capsule_overlaps(c, ck);
  for (std::size_t i = 0; i < c.solids.size(); ++i) check_solid(c, i, source);
  check_time(c, ck);
  check_output(c, ck);
}

}  // namespace detail

void validate_case(const CaseConfig& config, std::string_view source) {
  detail::validate_case(config, detail::CaseSource{.name = std::string(source)});
}

}  // namespace capsflow::io
