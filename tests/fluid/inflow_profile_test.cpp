// The pipe inflow profile (a circular tube's Poiseuille flow on a side of the brick):
// 2 U (1 - r^2 / R^2) within R of its axis, zero beyond, its mean over the disc U (midpoint
// sums over a fine grid of the side), on a side entered in either direction.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "fluid/flow_boundary.hpp"

namespace capsflow::fluid {
namespace {

constexpr double kTime = 0.0;

FlowConditions<3> pipe_on(int side, double radius, std::array<double, 3> centre, double mean) {
  const tree::TreeOptions<3> box{.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}};
  std::array<SideFlow<3>, 6> sides{};
  sides[1].kind = SideKind::outflow;
  sides[side] = {.kind = SideKind::inflow, .profile = InflowProfile::pipe, .mean_velocity = mean,
                 .pipe_radius = radius, .pipe_centre = centre};
  if (side == 1) sides[0].kind = SideKind::outflow;
  return make_flow_conditions<3>(sides, box, &kTime);
}

TEST(InflowProfile, PipeIsPoiseuilleOverItsDiscWithTheMeanVelocity) {
  const double R = 0.7, U = 1.3;
  const std::array<double, 3> axis{-4.0, 0.12, -0.05};  // off the side's centre
  const FlowConditions<3> fc = pipe_on(0, R, axis, U);
  const auto& un = fc.velocity[0].side[0];
  EXPECT_DOUBLE_EQ(un.at({-4.0, 0.12, -0.05}), 2.0 * U);
  EXPECT_DOUBLE_EQ(un.at({-4.0, 0.12 + 0.5 * R, -0.05}), 2.0 * U * 0.75);
  EXPECT_EQ(un.at({-4.0, 0.12 + R, -0.05}), 0.0);
  EXPECT_EQ(un.at({-4.0, 0.95, 0.95}), 0.0);
  EXPECT_EQ(fc.velocity[1].side[0].at({-4.0, 0.12, -0.05}), 0.0);  // no tangential velocity
  // The flux over the side divided by the disc's area: U to the midpoint sum's error.
  const int n = 2000;
  const double h = 2.0 / n;
  double flux = 0.0;
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < n; ++k) flux += un.at({-4.0, -1.0 + (j + 0.5) * h, -1.0 + (k + 0.5) * h}) * h * h;
  EXPECT_NEAR(flux / (M_PI * R * R), U, 2e-4);
}

TEST(InflowProfile, PipeOnAnUpperSideEntersTheDomain) {
  const FlowConditions<3> fc = pipe_on(1, 0.5, {4.0, 0.0, 0.0}, 2.0);
  EXPECT_DOUBLE_EQ(fc.velocity[0].side[1].at({4.0, 0.0, 0.0}), -4.0);  // along -x, into the domain
}

TEST(InflowProfile, PipeNeedsARadius) {
  EXPECT_THAT([] { (void)pipe_on(0, 0.0, {-4.0, 0.0, 0.0}, 1.0); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("the pipe profile needs a radius > 0")));
}

}  // namespace
}  // namespace capsflow::fluid
