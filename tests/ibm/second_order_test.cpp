// Second order in time for the coupled step (issue 17), in the fast suite: the relaxing
// ellipsoid of order_support.hpp (dx = 1/8, 642 P2 nodes, Re = 1, t = 0.016, dt = 2e-3,
// 1e-3, 5e-4 against 1.25e-4) with the midpoint node scheme, Crank-Nicolson viscosity, this
// step's force in the viscous solve and the projected faces carried from step to step
// (fluid::FlowOptions::carry_faces). Measured: N_inf 4.4e-5, 1.1e-5, 2.6e-6, orders 1.99,
// 2.06 (without the carried faces 7.2e-4, 3.6e-4, 1.6e-4, orders 1.02, 1.17; the default
// Euler / backward Euler 3.6e-3, 1.5e-3, 6.2e-4, orders 1.24, 1.30).
#include <gtest/gtest.h>

#include <cmath>

#include "order_support.hpp"

namespace capsflow::ibm {
namespace {

TEST(TimeOrder, MidpointWithCarriedFacesIsSecondOrder) {
  const auto e = test::errors({.crank_nicolson = true, .current_force = true, .carry_faces = true,
                               .scheme = NodeScheme::midpoint},
                              2e-3, "midpoint, Crank-Nicolson, current force, carried faces");
  EXPECT_GE(std::log2(e[0] / e[1]), 1.5);
  EXPECT_GE(std::log2(e[1] / e[2]), 1.5);
  EXPECT_LT(e[2], 1e-5);
}

}  // namespace
}  // namespace capsflow::ibm
