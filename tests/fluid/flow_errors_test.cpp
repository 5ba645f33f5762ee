// Bad flow input is refused with one message naming the key and the reason.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {
namespace {

using ::testing::HasSubstr;

std::string error_of(tree::TreeOptions<2> domain, FlowOptions<2> o) {
  try {
    tree::Tree<2> t(domain);
    NavierStokes<2> ns(t, o);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

TEST(FlowErrors, BadInputNamesTheKey) {
  const tree::TreeOptions<2> box{.roots = {1, 1}, .max_level = 3};
  FlowOptions<2> ok{};
  EXPECT_EQ(error_of(box, ok), "no error");

  auto o = ok;
  o.Re = -1;
  EXPECT_THAT(error_of(box, o), HasSubstr("fluid.Re = -1: must be > 0"));
  o = ok;
  o.viscosity = -0.5;
  EXPECT_THAT(error_of(box, o), HasSubstr("fluid.viscosity = -0.5: must be > 0"));
  o = ok;
  o.cfl = -0.3;
  EXPECT_THAT(error_of(box, o), HasSubstr("time.cfl = -0.3: must be >= 0"));
  o = ok;
  o.dt = 0;
  EXPECT_THAT(error_of(box, o), HasSubstr("time.dt = 0: must be > 0"));

  o = ok;  // periodic facing a wall
  o.boundaries[0].kind = SideKind::periodic;
  EXPECT_THAT(error_of(box, o), HasSubstr("fluid.boundary.x_lo: a periodic side must face a periodic side (x_hi is not)"));
  o = ok;  // periodic sides on a non-periodic domain
  o.boundaries[0].kind = o.boundaries[1].kind = SideKind::periodic;
  EXPECT_THAT(error_of(box, o), HasSubstr("fluid.boundary.x_lo: periodic, but domain.periodic is false"));
  o = ok;  // inflow on a periodic side
  tree::TreeOptions<2> periodic_x = box;
  periodic_x.periodic = {true, false};
  o.boundaries[0].kind = SideKind::inflow;
  EXPECT_THAT(error_of(periodic_x, o), HasSubstr("fluid.boundary.x_lo: domain.periodic is true in that direction"));
  o = ok;  // a moving wall that moves through itself
  o.boundaries[2] = {.kind = SideKind::moving_wall, .velocity = {0.0, 1.0}};
  EXPECT_THAT(error_of(box, o), HasSubstr("fluid.boundary.y_lo: a moving wall must move tangentially"));
  o = ok;  // the square-duct profile in 2D
  o.boundaries[0] = {.kind = SideKind::inflow, .profile = InflowProfile::square_duct};
  EXPECT_THAT(error_of(box, o), HasSubstr("fluid.boundary.x_lo: the square_duct profile needs a 3D domain"));
}

}  // namespace
}  // namespace capsflow::fluid
