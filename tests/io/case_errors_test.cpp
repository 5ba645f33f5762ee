// Each kind of bad case gives a CaseError with one line naming the file, the key and the
// reason.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <vector>

#include "case_error_of.hpp"
#include "io/case_config.hpp"

namespace capsflow::io {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// A valid 3D channel case; each test appends or replaces a piece of it.
constexpr std::string_view kBase = R"(dimension = 3
[domain]
roots = [4, 1, 1]
root_size = 2.0
origin = [-4, -1, -1]
periodic = [true, false, false]
[fluid.boundary]
y_lo = { type = "wall" }
y_hi = { type = "wall" }
z_lo = { type = "wall" }
z_hi = { type = "wall" }
)";

std::string replace(std::string text, std::string_view from, std::string_view to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

using testing::error_of;

TEST(io_case_errors, TheBaseCaseIsValid) { EXPECT_NO_THROW((void)parse_case_text(std::string(kBase), "case.toml")); }

// Found by the fuzz test: a 10 MB key or --set value made a 10 MB error line. Its two
// ends are kept (the file first, the reason last).
TEST(io_case_errors, HugeKeysAndValuesAreAbbreviated) {
  const std::string key(1'000'000, 'k');
  std::string message = error_of(std::string(kBase) + key + " = 1\n");
  EXPECT_LT(message.size(), 1000u);
  EXPECT_THAT(message, HasSubstr("characters ...]"));
  EXPECT_THAT(message, ::testing::EndsWith(": unknown key"));
  const std::vector<std::string> set{"fluid.Re=" + std::string(1'000'000, '[')};
  message = error_of(std::string(kBase), set);
  EXPECT_LT(message.size(), 1000u);
  EXPECT_THAT(message, ::testing::StartsWith("case.toml: --set fluid.Re="));
}

// profile = "pipe" (a circular tube's inflow): its radius is required, its axis defaults to
// the side's centre, both are written back; its keys belong to that profile only.
TEST(io_case_errors, PipeInflowProfileKeys) {
  const std::string channel = replace(std::string(kBase), "periodic = [true, false, false]", "");
  const std::string pipe = channel + "x_hi = { type = \"outflow\" }\n";
  const CaseConfig c = parse_case_text(
      pipe + "x_lo = { type = \"inflow\", profile = \"pipe\", radius = 0.9, mean_velocity = 2.0 }\n", "c");
  EXPECT_EQ(c.fluid.boundary[0].profile, InflowProfile::pipe);
  EXPECT_EQ(c.fluid.boundary[0].radius, 0.9);
  EXPECT_EQ(c.fluid.boundary[0].centre, (std::array{-4.0, 0.0, 0.0}));
  EXPECT_EQ(parse_case_text(to_toml(c), "c"), c);
  const CaseConfig off = parse_case_text(
      pipe + "x_lo = { type = \"inflow\", profile = \"pipe\", radius = 0.5, centre = [-4, 0.2, 0.1] }\n", "c");
  EXPECT_EQ(off.fluid.boundary[0].centre, (std::array{-4.0, 0.2, 0.1}));
  EXPECT_THAT(error_of(pipe + "x_lo = { type = \"inflow\", profile = \"pipe\" }\n"),
              HasSubstr("fluid.boundary.x_lo.radius"));
  EXPECT_THAT(error_of(pipe + "x_lo = { type = \"inflow\", profile = \"pipe\", radius = -1.0 }\n"),
              HasSubstr("fluid.boundary.x_lo.radius = -1.0: must be > 0"));
  EXPECT_THAT(error_of(pipe + "x_lo = { type = \"inflow\", profile = \"square_duct\", radius = 0.5 }\n"),
              HasSubstr("only used with profile = \"pipe\""));
}

TEST(io_case_errors, NegativeTimeStep) {
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ndt = -0.001\n"),
              HasSubstr("case.toml: time.dt = -0.001: must be > 0"));
}

// time.node_scheme and fluid.multigrid.fail_on_unconverged (issue 17): read, written back,
// and a word outside the list refused naming the key.
TEST(io_case_errors, NodeSchemeAndUnconvergedFailureKeys) {
  const CaseConfig c = parse_case_text(
      std::string(kBase) + "[fluid.multigrid]\nfail_on_unconverged = true\n[time]\nnode_scheme = \"midpoint\"\n", "c");
  EXPECT_EQ(c.time.node_scheme, NodeScheme::midpoint);
  EXPECT_TRUE(c.fluid.multigrid.fail_on_unconverged);
  EXPECT_EQ(parse_case_text(to_toml(c), "c"), c);
  EXPECT_EQ(parse_case_text(std::string(kBase), "c").time.node_scheme, NodeScheme::euler);
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\nnode_scheme = \"rk4\"\n"), HasSubstr("time.node_scheme"));
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid.multigrid]\nfail_on_unconverged = 1\n"),
              HasSubstr("fluid.multigrid.fail_on_unconverged"));
}

// time.coupling and the implicit solve's keys (issue 30): read, written back, defaults, and
// the values refused naming the key.
TEST(io_case_errors, ImplicitCouplingKeys) {
  const CaseConfig c = parse_case_text(std::string(kBase) +
                                           "[time]\ncoupling = \"implicit\"\nimplicit_tolerance = 1e-4\n"
                                           "implicit_max_iterations = 12\n",
                                       "c");
  EXPECT_EQ(c.time.coupling, Coupling::implicit_forces);
  EXPECT_EQ(c.time.implicit_tolerance, 1e-4);
  EXPECT_EQ(c.time.implicit_max_iterations, 12);
  EXPECT_EQ(parse_case_text(to_toml(c), "c"), c);
  const CaseConfig d = parse_case_text(std::string(kBase), "c");
  EXPECT_EQ(d.time.coupling, Coupling::explicit_forces);
  EXPECT_EQ(d.time.implicit_tolerance, 1e-3);
  EXPECT_EQ(d.time.implicit_max_iterations, 40);
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ncoupling = \"semi\"\n"), HasSubstr("time.coupling"));
  EXPECT_EQ(parse_case_text(std::string(kBase) + "[time]\ncoupling = \"auto\"\n", "c").time.coupling, Coupling::automatic);
  EXPECT_FALSE(d.fluid.current_force_in_viscous);
  EXPECT_EQ(d.time.tolerance, 0.0);
  const CaseConfig e = parse_case_text(std::string(kBase) + "[fluid]\ncurrent_force_in_viscous = true\n", "c");
  EXPECT_TRUE(e.fluid.current_force_in_viscous);
  EXPECT_EQ(parse_case_text(to_toml(e), "c"), e);
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ntolerance = 0.05\n"),
              HasSubstr("time.tolerance = 0.05: bounds the membrane nodes' error, and the case has no [[capsule]]"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ntolerance = -1\n"), HasSubstr("time.tolerance = -1.0: must be >= 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\nimplicit_tolerance = 1\n"),
              HasSubstr("time.implicit_tolerance = 1.0: must lie in (0, 1)"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\nimplicit_max_iterations = 0\n"),
              HasSubstr("time.implicit_max_iterations = 0: must be >= 1"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ncoupling = \"implicit\"\nnode_scheme = \"midpoint\"\n"),
              HasSubstr("time.node_scheme = \"midpoint\": the implicit coupling (time.coupling = \"implicit\" or "
                        "\"auto\") moves the nodes by Euler's or BDF2's rule"));
  // BDF2: the implicit coupling's, with the flow's BDF2 steps.
  const CaseConfig b = parse_case_text(std::string(kBase) + "[time]\ncoupling = \"auto\"\nnode_scheme = \"bdf2\"\n", "c");
  EXPECT_EQ(b.time.node_scheme, NodeScheme::bdf2);
  EXPECT_EQ(parse_case_text(to_toml(b), "c"), b);
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\nnode_scheme = \"bdf2\"\n"),
              HasSubstr("time.node_scheme = \"bdf2\": BDF2's rule runs with time.coupling = \"auto\""));
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\ncarry_faces = true\n[time]\ncoupling = \"implicit\"\n"
                                            "node_scheme = \"bdf2\"\n"),
              HasSubstr("time.node_scheme = \"bdf2\": BDF2 steps the flow by BDF2 too, with neither fluid.carry_faces"));
  // The pressure iterations of BDF2's steps.
  EXPECT_EQ(b.fluid.pressure_iterations, 0);
  const CaseConfig p = parse_case_text(std::string(kBase) + "[fluid]\npressure_iterations = 3\n[time]\ncoupling = "
                                                            "\"implicit\"\nnode_scheme = \"bdf2\"\n",
                                       "c");
  EXPECT_EQ(p.fluid.pressure_iterations, 3);
  EXPECT_EQ(parse_case_text(to_toml(p), "c"), p);
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\npressure_iterations = 3\n"),
              HasSubstr("fluid.pressure_iterations = 3: iterates the pressure of BDF2's steps"));
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\npressure_iterations = -1\n"),
              HasSubstr("fluid.pressure_iterations = -1"));
}

TEST(io_case_errors, MaxLevelBelowMinLevel) {
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nmin_level = 5\nmax_level = 3\n"),
              HasSubstr("adapt.max_level = 3: must be >= adapt.min_level (5)"));
}

TEST(io_case_errors, LevelAboveWhatTheTreeAllows) {
  const std::string e = error_of(std::string(kBase) + "[adapt]\nmax_level = 40\n");
  EXPECT_THAT(e, HasSubstr("adapt.max_level = 40: above 19, the deepest level the tree allows"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nwall_level = 9\n"),
              HasSubstr("adapt.wall_level = 9: must be <= adapt.max_level (6)"));
}

TEST(io_case_errors, CapsuleThatDoesNotFitTheChannel) {
  const std::string capsule = "[[capsule]]\nradius = 0.5\ncentre = [0, 0.2, 0]\nshape = \"ellipsoid\"\n"
                              "axes_factors = [1, 1.7, 1]\n";
  const std::string e = error_of(std::string(kBase) + capsule);
  EXPECT_THAT(e, HasSubstr("capsule[0].centre = [0.0, 0.2, 0.0]"));
  EXPECT_THAT(e, HasSubstr("does not fit inside the domain: along y its centre +- 0.85"));
  // The same capsule as a sphere fits.
  EXPECT_NO_THROW((void)parse_case_text(replace(std::string(kBase) + capsule, "\"ellipsoid\"", "\"sphere\""), "c"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nradius = 0.9\ncentre = [0, 0, 0]\nshape = \"inflated\"\n"
                                            "inflation = 1.2\n"),
              HasSubstr("does not fit inside the domain: along y its centre +- 1.08"));
}

TEST(io_case_errors, PeriodicSideFacingANonPeriodicOne) {
  const std::string text = replace(std::string(kBase), "y_lo = { type = \"wall\" }", "y_lo = { type = \"periodic\" }");
  EXPECT_THAT(error_of(text), HasSubstr("fluid.boundary.y_lo.type = \"periodic\": a periodic side cannot face "
                                        "a non-periodic one (y_hi is \"wall\")"));
  const std::string both = replace(text, "y_hi = { type = \"wall\" }", "y_hi = { type = \"periodic\" }");
  EXPECT_THAT(error_of(both), HasSubstr("fluid.boundary.y_lo.type = \"periodic\": domain.periodic is false along y"));
}

TEST(io_case_errors, InflowOnAPeriodicSide) {
  const std::string text = std::string(kBase) + "x_lo = { type = \"inflow\", profile = \"parabolic\" }\n";
  EXPECT_THAT(error_of(text), HasSubstr("fluid.boundary.x_lo.type = \"inflow\": x is periodic (domain.periodic)"));
  const std::string profile = std::string(kBase) + "x_lo = { type = \"periodic\", profile = \"parabolic\" }\n";
  EXPECT_THAT(error_of(profile),
              HasSubstr("fluid.boundary.x_lo.profile = \"parabolic\": only used with type = \"inflow\""));
}

TEST(io_case_errors, NegativeReViscosityOrCfl) {
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\nRe = -1\n"), HasSubstr("fluid.Re = -1.0: must be > 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nradius = 0.2\ncentre = [0,0,0]\nviscosity_ratio = -2.5\n"),
              HasSubstr("capsule[0].viscosity_ratio = -2.5: must be > 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nradius = 0.2\ncentre = [0,0,0]\ndensity_ratio = 0\n"),
              HasSubstr("capsule[0].density_ratio = 0.0: must be > 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ncfl = -0.5\n"), HasSubstr("time.cfl = -0.5: must be >= 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nvelocity_tolerance_relative = -0.01\n"),
              HasSubstr("adapt.velocity_tolerance_relative = -0.01: must be >= 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\ninterval = 4\nmax_interval = 2\n"),
              HasSubstr("adapt.max_interval = 2: must be 0 (off) or >= adapt.interval (4)"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\ninterval_time = -0.01\n"),
              HasSubstr("adapt.interval_time = -0.01: must be >= 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\ninterval = 4\ninterval_time = 0.004\n"),
              HasSubstr("adapt.interval_time = 0.004: replaces adapt.interval and adapt.max_interval"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\ninterval_time = 0.004\nmax_interval_time = 0.002\n"),
              HasSubstr("adapt.max_interval_time = 0.002: must be 0 (off) or >= adapt.interval_time (0.004)"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nmax_interval_time = 0.002\n"),
              HasSubstr("adapt.max_interval_time = 0.002: needs adapt.interval_time > 0"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nmembrane_weight = 0\n"),
              HasSubstr("adapt.membrane_weight = 0: must be >= 1"));
}

// The inner fluid belongs to each capsule: the old global keys are refused, even at 1, with
// the key that replaces them.
TEST(io_case_errors, GlobalInnerFluidRatiosNameTheCapsulesKeys) {
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\ndensity_ratio = 2.0\n"),
              HasSubstr("fluid.density_ratio = 2.0: the inner fluid is now given per capsule: set density_ratio in "
                        "each [[capsule]] table"));
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\nviscosity_ratio = 1.0\n"),
              HasSubstr("fluid.viscosity_ratio = 1.0: the inner fluid is now given per capsule: set viscosity_ratio "
                        "in each [[capsule]] table"));
  const CaseConfig c = parse_case_text(
      std::string(kBase) + "[[capsule]]\nradius = 0.2\ncentre = [0,0,0]\nviscosity_ratio = 5\ndensity_ratio = 2\n",
      "case.toml");
  EXPECT_EQ(c.capsules[0].viscosity_ratio, 5.0);
  EXPECT_EQ(c.capsules[0].density_ratio, 2.0);
}

TEST(io_case_errors, MissingBoundaryCondition) {
  const std::string text = replace(std::string(kBase), "y_hi = { type = \"wall\" }\n", "");
  EXPECT_THAT(error_of(text), HasSubstr("case.toml: fluid.boundary.y_hi: missing (y is not periodic"));
  const std::string no_type = replace(std::string(kBase), "y_hi = { type = \"wall\" }", "y_hi = { }");
  EXPECT_THAT(error_of(no_type), HasSubstr("fluid.boundary.y_hi.type: missing"));
  const std::string moving = replace(std::string(kBase), "y_hi = { type = \"wall\" }", "y_hi = { type = \"moving_wall\" }");
  EXPECT_THAT(error_of(moving), HasSubstr("fluid.boundary.y_hi.velocity: missing"));
}

TEST(io_case_errors, MovingWallThatMovesThroughItself) {
  const std::string text = replace(std::string(kBase), "y_hi = { type = \"wall\" }",
                                   "y_hi = { type = \"moving_wall\", velocity = [1, 0.5, 0] }");
  EXPECT_THAT(error_of(text), HasSubstr("fluid.boundary.y_hi.velocity = [1.0, 0.5, 0.0]: the normal component (y) must be 0"));
}

TEST(io_case_errors, MissingFile) {
  try {
    (void)parse_case("/nonexistent/dir/case.toml");
    FAIL() << "no CaseError";
  } catch (const CaseError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("/nonexistent/dir/case.toml: cannot read the case file"));
  }
}

TEST(io_case_errors, SyntaxErrorGivesLineAndColumn) {
  const std::string e = error_of("dimension = 3\n[domain]\nroots = [4, 1,\n");
  EXPECT_THAT(e, HasSubstr("case.toml: line 3"));
  EXPECT_THAT(e, HasSubstr("column"));
  EXPECT_THAT(error_of("dimension = = 3\n"), HasSubstr("case.toml: line 1, column"));
}

TEST(io_case_errors, UnknownKeysAnywhere) {
  EXPECT_THAT(error_of("colour = 1\n" + std::string(kBase)), HasSubstr("case.toml: colour: unknown key"));
  EXPECT_THAT(error_of("[fluids]\nRe = 1\n"), HasSubstr("case.toml: fluids: unknown key (did you mean fluid?)"));
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\nRey = 10\n"),
              HasSubstr("fluid.Rey: unknown key (did you mean fluid.Re?)"));
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid.multigrid]\ncycles = 3\n"),
              HasSubstr("fluid.multigrid.cycles: unknown key"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nradius = 0.2\ncentre = [0,0,0]\nradios = 1\n"),
              HasSubstr("capsule[0].radios: unknown key (did you mean capsule[0].radius?)"));
  EXPECT_THAT(error_of(replace(std::string(kBase), "y_lo = { type = \"wall\" }", "y_lo = { type = \"wall\", slip = true }")),
              HasSubstr("fluid.boundary.y_lo.slip: unknown key"));
  EXPECT_THAT(error_of(std::string(kBase) + "w_lo = { type = \"wall\" }\n"), HasSubstr("fluid.boundary.w_lo: unknown key"));
}

TEST(io_case_errors, WrongTypes) {
  EXPECT_THAT(error_of(std::string(kBase) + "[fluid]\nRe = \"ten\"\n"),
              HasSubstr("fluid.Re = \"ten\": expected a number, got a string"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nenabled = 1\n"),
              HasSubstr("adapt.enabled = 1: expected a boolean (true or false), got an integer"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nmax_level = 6.5\n"),
              HasSubstr("adapt.max_level = 6.5: expected an integer, got a float"));
  EXPECT_THAT(error_of(replace(std::string(kBase), "roots = [4, 1, 1]", "roots = [4, 1]")),
              HasSubstr("domain.roots = [4, 1]: expected 3 entries (one per direction), got 2"));
  EXPECT_THAT(error_of(replace(std::string(kBase), "roots = [4, 1, 1]", "roots = [4, 1.5, 1]")),
              HasSubstr("domain.roots = [4, 1.5, 1]: entry 1 is a float, expected an integer"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ndt = [1]\n"), HasSubstr("time.dt = [1]: expected a number, got an array"));
  EXPECT_THAT(error_of("dimension = 3\ndomain = 4\n"), HasSubstr("domain = 4: expected a table, got an integer"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nradius = 0.2\ncentre = [0,0,0]\nlaw = \"hooke\"\n"),
              HasSubstr("capsule[0].law = \"hooke\": expected one of \"skalak\", \"neo_hookean\""));
}

TEST(io_case_errors, OtherImpossibleValues) {
  EXPECT_THAT(error_of("dimension = 4\n"), HasSubstr("case.toml: dimension = 4: must be 2 or 3"));
  EXPECT_THAT(error_of(replace(std::string(kBase), "roots = [4, 1, 1]", "roots = [4, 0, 1]")),
              HasSubstr("domain.roots[1] = 0: must be >= 1"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nradius = 0.2\ncentre = [0,0,0]\nnodes = 1000\n"),
              HasSubstr("capsule[0].nodes = 1000: must be 642, 2562, 10242 or 40962"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nradius = 0.2\ncentre = [0,0,0]\nC = -0.7\n"),
              HasSubstr("capsule[0].C = -0.7: must be > -0.5"));
  // Ignored by the neo-Hookean law, but written back to case.toml: a NaN would not read back.
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\nlaw = \"neo_hookean\"\nradius = 0.2\ncentre = [0,0,0]\nC = nan\n"),
              HasSubstr("capsule[0].C = nan: must be finite"));
  EXPECT_THAT(error_of(std::string(kBase) + "[[capsule]]\ncentre = [0,0,0]\n"), HasSubstr("capsule[0].radius: missing"));
  EXPECT_THAT(error_of("dimension = 2\n[fluid.boundary]\nx_lo = {type=\"wall\"}\nx_hi = {type=\"wall\"}\n"
                       "y_lo = {type=\"wall\"}\ny_hi = {type=\"wall\"}\nz_lo = {type=\"wall\"}\n"),
              HasSubstr("fluid.boundary.z_lo: there is no z side in a 2D case"));
  EXPECT_THAT(error_of("dimension = 2\n[domain]\nperiodic = [true, true]\n[[capsule]]\nradius = 0.1\n"
                       "centre = [0.5, 0.5, 0.5]\n"),
              HasSubstr("capsule[0]: capsules need dimension = 3"));
  EXPECT_THAT(error_of(std::string(kBase) + "[output]\ninterval = 0\n"), HasSubstr("output.interval = 0: must be >= 1"));
}

TEST(io_case_errors, FileNameIsTheOneGiven) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "capsflow_io_case_errors";
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "bad.toml";
  std::ofstream(file) << kBase << "[time]\ndt = 0\n";
  try {
    (void)parse_case(file);
    FAIL() << "no CaseError";
  } catch (const CaseError& e) {
    EXPECT_EQ(std::string(e.what()), file.string() + ": time.dt = 0.0: must be > 0");
  }
  std::filesystem::remove_all(dir);
}

// Two capsules may not start inside one another: the spheres around their initial shapes
// (radius: the largest semi-axis) must be disjoint.
TEST(io_case_errors, OverlappingCapsules) {
  const std::string two = std::string(kBase) + "[[capsule]]\nradius = 0.3\ncentre = [0, 0, 0]\n" +
                          "[[capsule]]\nradius = 0.3\ncentre = [0, 0, 0]\n";
  EXPECT_THAT(error_of(two), HasSubstr("capsule[1].centre = [0.0, 0.0, 0.0]: overlaps capsule[0]: the centres are 0 apart"));
  // An ellipsoid reaches farther than its radius along its long axis.
  const std::string near = std::string(kBase) + "[[capsule]]\nradius = 0.3\ncentre = [-1, 0, 0]\n" +
                           "[[capsule]]\nradius = 0.3\ncentre = [-0.3, 0, 0]\nshape = \"ellipsoid\"\n" +
                           "axes_factors = [1.5, 0.5, 0.5]\n";
  EXPECT_THAT(error_of(near), HasSubstr("capsule[1].centre = [-0.3, 0.0, 0.0]: overlaps capsule[0]"));
  EXPECT_NO_THROW((void)parse_case_text(replace(near, "centre = [-0.3, 0, 0]", "centre = [0.0, 0, 0]"), "c"));
}

// A node closer to a non-periodic side than its kernels reach would need cells outside the
// domain at the first step: on faces W/2 max-level cells (the divergence-free forms
// W/2 + 1: cosine 3 cells of 2/64 = 0.094 at the default max_level 6), on cells (W - 1)/2.
TEST(io_case_errors, CapsuleWithinTheKernelsReachOfAWall) {
  const std::string capsule = std::string(kBase) + "[[capsule]]\nradius = 0.5\ncentre = [0, 0.46, 0]\n";
  const std::string e = error_of(capsule);
  EXPECT_THAT(e, HasSubstr("capsule[0].centre = [0.0, 0.46, 0.0]: the capsule is 0.04 from a side along y, "
                           "within its kernels' reach (0.09375"));
  EXPECT_THAT(error_of(replace(capsule, "0.46", "0.41")), HasSubstr("within its kernels' reach (0.09375"));
  EXPECT_NO_THROW((void)parse_case_text(replace(capsule, "0.46", "0.40"), "c"));
  const std::string faces = capsule + "divergence_free = false\n";
  EXPECT_THAT(error_of(faces), HasSubstr("within its kernels' reach (0.0625"));
  EXPECT_NO_THROW((void)parse_case_text(replace(faces, "0.46", "0.43"), "c"));
  // Staggered stencils reach W/2 cells, the cell-centred ones (W - 1)/2.
  EXPECT_THAT(error_of(replace(faces, "0.46", "0.45")), HasSubstr("within its kernels' reach (0.0625"));
  EXPECT_NO_THROW((void)parse_case_text(replace(capsule, "0.46", "0.45") + "staggered = false\n", "c"));
  // The hat kernel alone reaches one cell on faces, two in its divergence-free form.
  const std::string hat = "spread_kernel = \"hat\"\ninterp_kernel = \"hat\"\n";
  EXPECT_NO_THROW((void)parse_case_text(faces + hat, "c"));
  EXPECT_THAT(error_of(capsule + hat), HasSubstr("within its kernels' reach (0.0625"));
  // Along a periodic direction there is no side to reach.
  EXPECT_NO_THROW((void)parse_case_text(std::string(kBase) + "[[capsule]]\nradius = 0.5\ncentre = [-3.5, 0, 0]\n", "c"));
}

// Magnitudes no run means: a step so small that t_end takes more than 1e9 of them (5e-324
// is a denormal), lengths beyond 1e9 half-widths (1e308 overflows the brick's size).
TEST(io_case_errors, AbsurdMagnitudes) {
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ndt = 5e-324\n"),
              HasSubstr("time.dt = 5e-324: time.t_end / time.dt = inf steps, more than 1e+09"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ndt = 1e-10\nt_end = 1.0\n"),
              HasSubstr("time.dt = 1e-10: time.t_end / time.dt = 1e+10 steps"));
  EXPECT_THAT(error_of(std::string(kBase) + "[time]\ncfl = 0.5\ndt_max = 1e-12\n"), HasSubstr("time.dt_max = 1e-12: "));
  EXPECT_THAT(error_of(replace(std::string(kBase), "root_size = 2.0", "root_size = 1e308")),
              HasSubstr("domain.root_size = 1e+308: must be in [1e-09, 1e+09]"));
  EXPECT_THAT(error_of(replace(std::string(kBase), "origin = [-4, -1, -1]", "origin = [-4, -1e300, -1]")),
              HasSubstr("domain.origin[1] = -1e+300: |origin| must be <= 1e+09"));
}

TEST(io_case_errors, IntegersOutOfRangeAndArrayTypes) {
  EXPECT_THAT(error_of(replace(std::string(kBase), "roots = [4, 1, 1]", "roots = [4000000000, 1, 1]")),
              HasSubstr("domain.roots = [4000000000, 1, 1]: entry 0 is out of range for a 32-bit integer"));
  EXPECT_THAT(error_of(std::string(kBase) + "[adapt]\nmax_level = 4000000000\n"),
              HasSubstr("adapt.max_level = 4000000000: out of range for a 32-bit integer"));
  EXPECT_THAT(error_of(replace(std::string(kBase), "roots = [4, 1, 1]", "roots = 4")),
              HasSubstr("domain.roots = 4: expected an array of 3 integers, got an integer"));
  EXPECT_THAT(error_of(replace(std::string(kBase), "origin = [-4, -1, -1]", "origin = -4")),
              HasSubstr("domain.origin = -4: expected an array of 3 numbers, got an integer"));
}

TEST(io_case_errors, OverrideIndexOutOfRange) {
  const std::string text = std::string(kBase) + "[[capsule]]\nradius = 0.3\ncentre = [0, 0, 0]\n";
  const std::vector<std::string> huge{"capsule[99999999999999999999999].radius=1"};
  EXPECT_THAT(error_of(text, huge),
              HasSubstr("--set capsule[99999999999999999999999].radius=1: index 99999999999999999999999 in key "
                        "\"capsule[99999999999999999999999].radius\" is out of range"));
  const std::vector<std::string> past{"capsule[3].radius=1"};
  EXPECT_THAT(error_of(text, past), HasSubstr("capsule[3] does not exist (the case has 1)"));
}

}  // namespace
}  // namespace capsflow::io
