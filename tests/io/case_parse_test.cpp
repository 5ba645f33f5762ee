// A full case parses to the expected values, defaults fill the rest, and to_toml writes a
// case that parses back to the same struct.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "io/case_config.hpp"

namespace capsflow::io {
namespace {

const std::filesystem::path kData = CAPSFLOW_IO_TEST_DATA;

TEST(io_case_parse, EveryKeyOfAFullCase) {
  const CaseConfig c = parse_case(kData / "full.toml");
  EXPECT_EQ(c.name, "relaxation");
  EXPECT_EQ(c.dimension, 3);
  EXPECT_EQ(c.domain.roots, (std::array{4, 1, 1}));
  EXPECT_EQ(c.domain.root_size, 2.0);
  EXPECT_EQ(c.domain.origin, (std::array{-4.0, -1.0, -1.0}));
  EXPECT_EQ(c.domain.periodic, (std::array{true, false, false}));

  EXPECT_EQ(c.fluid.Re, 10.0);
  EXPECT_TRUE(c.fluid.stokes);
  EXPECT_EQ(c.fluid.multigrid.tolerance, 1e-4);
  EXPECT_EQ(c.fluid.multigrid.max_cycles, 30);
  const auto& b = c.fluid.boundary;
  EXPECT_EQ(b[0].type, BoundaryType::periodic);  // x sides left out: x is periodic
  EXPECT_EQ(b[1].type, BoundaryType::periodic);
  EXPECT_EQ(b[2].type, BoundaryType::wall);
  EXPECT_EQ(b[3].type, BoundaryType::moving_wall);
  EXPECT_EQ(b[3].velocity, (std::array{0.5, 0.0, 0.25}));
  EXPECT_EQ(b[4].type, BoundaryType::inflow);
  EXPECT_EQ(b[4].profile, InflowProfile::square_duct);
  EXPECT_EQ(b[4].mean_velocity, 0.75);
  EXPECT_EQ(b[5].type, BoundaryType::outflow);

  EXPECT_FALSE(c.adapt.enabled);
  EXPECT_EQ(c.adapt.min_level, 3);
  EXPECT_EQ(c.adapt.max_level, 7);
  EXPECT_EQ(c.adapt.velocity_tolerance, 0.005);
  EXPECT_EQ(c.adapt.velocity_tolerance_relative, 0.02);
  EXPECT_EQ(c.adapt.wall_level, 5);
  EXPECT_EQ(c.adapt.membrane_band, 3);
  EXPECT_EQ(c.adapt.membrane_weight, 6);
  EXPECT_EQ(c.adapt.interval, 2);
  EXPECT_EQ(c.adapt.max_interval, 6);

  ASSERT_EQ(c.capsules.size(), 2u);
  const CapsuleConfig& k = c.capsules[0];
  EXPECT_EQ(k.law, MembraneLaw::neo_hookean);
  EXPECT_EQ(k.Ca, 0.05);
  EXPECT_EQ(k.C, 2.0);
  EXPECT_EQ(k.nodes, 10242);
  EXPECT_EQ(k.element_order, 2);
  EXPECT_EQ(k.radius, 0.3);
  EXPECT_EQ(k.centre, (std::array{0.5, 0.1, -0.1}));
  EXPECT_EQ(k.shape, InitialShape::ellipsoid);
  EXPECT_EQ(k.axes_factors, (std::array{2.0, 0.7071067811865476, 0.7071067811865476}));
  EXPECT_EQ(k.inflation, 1.1);
  EXPECT_EQ(k.spread_kernel, KernelType::peskin4);
  EXPECT_EQ(k.interp_kernel, KernelType::cosine);
  EXPECT_EQ(k.viscosity_ratio, 5.0);
  EXPECT_EQ(k.density_ratio, 0.5);
  const CapsuleConfig& k2 = c.capsules[1];  // only radius, centre, shape, inflation given
  EXPECT_EQ(k2.shape, InitialShape::inflated);
  EXPECT_EQ(k2.inflation, 1.5);
  EXPECT_EQ(k2.law, MembraneLaw::skalak);
  EXPECT_EQ(k2.nodes, 2562);
  EXPECT_EQ(k2.spread_kernel, KernelType::cosine);
  EXPECT_EQ(k2.interp_kernel, KernelType::cosine);
  EXPECT_EQ(k2.viscosity_ratio, 1.0);  // the same fluid inside
  EXPECT_EQ(k2.density_ratio, 1.0);

  EXPECT_EQ(c.time.dt, 0.0005);
  EXPECT_EQ(c.time.t_end, 3.5);
  EXPECT_EQ(c.time.cfl, 0.4);
  EXPECT_EQ(c.time.dt_max, 0.002);

  EXPECT_EQ(c.output.interval, 50);
  EXPECT_EQ(c.output.diagnostics_interval, 5);
  EXPECT_FALSE(c.output.vtu);
  EXPECT_TRUE(c.output.checkpoint);
  EXPECT_EQ(c.output.checkpoint_interval, 1000);
  EXPECT_TRUE(c.output.cells_csv);
  EXPECT_EQ(c.output.directory, "results/relax");
}

TEST(io_case_parse, DefaultsFillEverythingNotGiven) {
  const CaseConfig c = parse_case(kData / "cavity2d.toml");
  CaseConfig expected;
  expected.name = "cavity2d";  // the file's stem
  expected.dimension = 2;
  expected.fluid.boundary[3] = {.type = BoundaryType::moving_wall, .velocity = {1.0, 0.0, 0.0}};
  expected.output.directory = "out/cavity2d";
  EXPECT_EQ(c, expected);
  // The documented defaults, spelled out once.
  EXPECT_EQ(c.domain.roots, (std::array{1, 1, 1}));
  EXPECT_EQ(c.domain.root_size, 1.0);
  EXPECT_EQ(c.fluid.Re, 1.0);
  EXPECT_FALSE(c.fluid.stokes);
  EXPECT_EQ(c.fluid.multigrid.tolerance, 1e-3);
  EXPECT_EQ(c.fluid.multigrid.max_cycles, 50);
  EXPECT_FALSE(c.fluid.crank_nicolson);
  EXPECT_FALSE(c.fluid.carry_faces);
  EXPECT_TRUE(c.adapt.enabled);
  EXPECT_EQ(c.adapt.min_level, 2);
  EXPECT_EQ(c.adapt.max_level, 6);
  EXPECT_EQ(c.adapt.wall_level, 0);
  EXPECT_TRUE(c.capsules.empty());
  EXPECT_EQ(c.time.dt, 1e-3);
  EXPECT_EQ(c.time.cfl, 0.0);
  EXPECT_EQ(c.output.interval, 100);
  EXPECT_TRUE(c.output.vtu);
  EXPECT_FALSE(c.output.checkpoint);
  EXPECT_EQ(c.output.checkpoint_interval, 0);
}

TEST(io_case_parse, AnEmptyCapsuleArrayMeansNoCapsules) {
  const CaseConfig c = parse_case_text("dimension = 2\ncapsule = []\n[domain]\nperiodic = [true, true]\n", "p.toml");
  EXPECT_TRUE(c.capsules.empty());
  EXPECT_EQ(c.fluid.boundary[0].type, BoundaryType::periodic);
  EXPECT_EQ(c.fluid.boundary[3].type, BoundaryType::periodic);
  EXPECT_EQ(c.name, "p");
}

TEST(io_case_parse, ToTomlRoundTrips) {
  for (const char* file : {"full.toml", "cavity2d.toml"}) {
    const CaseConfig c = parse_case(kData / file);
    const std::string text = to_toml(c);
    const CaseConfig back = parse_case_text(text, "written.toml");
    EXPECT_EQ(back, c) << file << ":\n" << text;
    EXPECT_EQ(to_toml(back), text);  // and writing is stable
  }
}

TEST(io_case_parse, ToTomlKeepsAwkwardDoublesExactly) {
  CaseConfig c = parse_case(kData / "cavity2d.toml");
  c.time.dt = 0.1 + 0.2;  // 0.30000000000000004
  c.time.t_end = 1.0 / 3.0;
  c.fluid.Re = 1e22;
  c.adapt.velocity_tolerance = 5e-324;  // the smallest subnormal
  c.name = "quote\" and backslash\\";
  const CaseConfig back = parse_case_text(to_toml(c), "written.toml");
  EXPECT_EQ(back, c);
}

// Found by the fuzz test: a name with DEL (U+007F, "\u007f" in the file) was written raw
// into case.toml, which then did not read back.
TEST(io_case_parse, ToTomlEscapesControlCharacters) {
  CaseConfig c = parse_case(kData / "cavity2d.toml");
  c.name = std::string("del\x7f tab\t nul") + '\0' + " bell\x07";
  const CaseConfig back = parse_case_text(to_toml(c), "written.toml");
  EXPECT_EQ(back, c);
}

TEST(io_case_parse, TreeOptionsFollowTheDomain) {
  const CaseConfig c = parse_case(kData / "full.toml");
  const tree::TreeOptions<3> o = tree_options<3>(c);
  EXPECT_EQ(o.roots, (std::array{4, 1, 1}));
  EXPECT_EQ(o.root_size, 2.0);
  EXPECT_EQ(o.origin, (tree::Point<3>{-4.0, -1.0, -1.0}));
  EXPECT_EQ(o.periodic, (std::array{true, false, false}));
  EXPECT_EQ(o.max_level, 7);
  EXPECT_GE(max_tree_level(c), 17);
}

}  // namespace
}  // namespace capsflow::io
