// --set key=value overrides: values, nested keys, array elements, and the errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "io/case_config.hpp"

namespace capsflow::io {
namespace {

using ::testing::HasSubstr;

const std::filesystem::path kData = CAPSFLOW_IO_TEST_DATA;

CaseConfig with(std::vector<std::string> sets) { return parse_case(kData / "full.toml", sets); }

std::string error_with(std::vector<std::string> sets) {
  try {
    (void)parse_case(kData / "full.toml", sets);
  } catch (const CaseError& e) {
    EXPECT_THAT(std::string(e.what()), ::testing::Not(HasSubstr("\n")));
    EXPECT_THAT(std::string(e.what()), HasSubstr("full.toml: "));
    return e.what();
  }
  ADD_FAILURE() << "no CaseError";
  return {};
}

TEST(io_case_overrides, AValue) {
  EXPECT_EQ(with({"fluid.Re=3"}).fluid.Re, 3.0);
  EXPECT_EQ(with({"adapt.enabled=true"}).adapt.enabled, true);
  EXPECT_EQ(with({"name=\"other\""}).name, "other");
  EXPECT_EQ(with({" time.dt = 2.5e-4 "}).time.dt, 2.5e-4);
  const CaseConfig second = with({"fluid.crank_nicolson=true", "fluid.carry_faces=true", "capsule[0].divergence_free=false"});
  EXPECT_TRUE(second.fluid.crank_nicolson);
  EXPECT_TRUE(second.fluid.carry_faces);
  EXPECT_FALSE(second.capsules[0].divergence_free);
}

TEST(io_case_overrides, NestedValuesArraysAndTables) {
  const CaseConfig c = with({"fluid.multigrid.tolerance=1e-6", "domain.roots=[8,1,1]", "capsule[1].radius=0.25",
                             "capsule[0].law=skalak", "fluid.boundary.y_lo={type=\"moving_wall\", velocity=[2,0,0]}"});
  EXPECT_EQ(c.fluid.multigrid.tolerance, 1e-6);
  EXPECT_EQ(c.domain.roots, (std::array{8, 1, 1}));
  EXPECT_EQ(c.capsules[1].radius, 0.25);
  EXPECT_EQ(c.capsules[0].law, MembraneLaw::skalak);  // a bare word is a string
  EXPECT_EQ(c.fluid.boundary[2].type, BoundaryType::moving_wall);
  EXPECT_EQ(c.fluid.boundary[2].velocity, (std::array{2.0, 0.0, 0.0}));
  // A section the file does not have is created.
  const CaseConfig cavity = parse_case(kData / "cavity2d.toml", std::vector<std::string>{"time.t_end=9"});
  EXPECT_EQ(cavity.time.t_end, 9.0);
  // Later overrides win.
  EXPECT_EQ(with({"fluid.Re=3", "fluid.Re=4"}).fluid.Re, 4.0);
}

TEST(io_case_overrides, UnknownKeyIsAnError) {
  EXPECT_THAT(error_with({"fluid.Rey=10"}), HasSubstr("full.toml: fluid.Rey (from --set): unknown key (did you mean fluid.Re?)"));
  EXPECT_THAT(error_with({"solver.tolerance=1"}), HasSubstr("solver (from --set): unknown key"));
  EXPECT_THAT(error_with({"capsule[2].radius=1"}), HasSubstr("--set capsule[2].radius=1: capsule[2] does not exist (the case has 2)"));
}

TEST(io_case_overrides, WrongTypeIsAnError) {
  EXPECT_THAT(error_with({"fluid.Re=abc"}),
              HasSubstr("fluid.Re = \"abc\" (from --set): expected a number, got a string"));
  EXPECT_THAT(error_with({"adapt.max_level=7.5"}),
              HasSubstr("adapt.max_level = 7.5 (from --set): expected an integer, got a float"));
  EXPECT_THAT(error_with({"fluid.Re.x=1"}), HasSubstr("--set fluid.Re.x=1: Re is not a table"));
}

TEST(io_case_overrides, BadSyntaxAndRanges) {
  EXPECT_THAT(error_with({"fluid.Re"}), HasSubstr("--set fluid.Re: expected key=value"));
  EXPECT_THAT(error_with({"domain.roots=[4,1"}), HasSubstr("--set domain.roots=[4,1: the value is not valid TOML"));
  EXPECT_THAT(error_with({"time.dt=-1"}), HasSubstr("time.dt = -1.0 (from --set): must be > 0"));
  EXPECT_THAT(error_with({"adapt.max_level=2"}),
              HasSubstr("adapt.max_level = 2 (from --set): must be >= adapt.min_level (3)"));
}

}  // namespace
}  // namespace capsflow::io
