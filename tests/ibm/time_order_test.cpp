// Time order of the coupled step (capsule_coupling.hpp, stage 5), labelled long (two to
// three minutes): the seed's relaxing ellipsoid, coarse (dx = 1/8, 642 P2 nodes, a uniform
// grid so that every run sees the same cells), to t = 0.016 with dt = 2e-3, 1e-3, 5e-4 and
// a reference at 1.25e-4 of the same scheme; N_inf = max over nodes of |X - X_ref|.
// Measured (Re = 1, backward Euler viscosity unless said):
//   Euler     N_inf 3.7e-3, 1.6e-3, 6.3e-4   orders 1.24, 1.29
//   AB2             6.1e-3, 2.9e-3, 1.2e-3          1.09, 1.22  (Crank-Nicolson: 1.05, 1.20)
//   midpoint        5.7e-4, 2.6e-4, 1.4e-4          1.13, 0.91  (Crank-Nicolson: 9.3e-4,
//                                                                6.0e-4, 2.9e-4; 0.65, 1.03)
// With the divergence-free kernels (the default since): the same to two digits (Euler
// 3.6e-3, 1.5e-3, 6.2e-4; AB2 6.0e-3, 2.8e-3, 1.2e-3; midpoint 5.3e-4, 2.5e-4, 1.4e-4).
// All first order: the node update is not what limits the order (issue 17 wants >= 1.5);
// the implicit coupling (issue 30) too (its own test below, a dt ladder without a reference).
// neither Crank-Nicolson (its explicit half fixed) nor this step's force in the viscous
// solve raised it (docs/numerics.md lists what was tried and what is left).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "order_support.hpp"

namespace capsflow::ibm {
namespace {

using test::errors;
using test::OrderRun;

TEST(TimeOrder, CoupledStepIsFirstOrderAndMidpointIsMoreAccurate) {
  const double dt0 = 2e-3;  // a third of Ca dx = 6.25e-3
  const auto euler = errors({.scheme = NodeScheme::euler}, dt0, "Euler");
  const auto ab2 = errors({}, dt0, "AB2");
  const auto mid = errors({.scheme = NodeScheme::midpoint}, dt0, "midpoint");
  for (const auto& e : {euler, ab2, mid}) EXPECT_GE(std::log2(e[1] / e[2]), 0.8);  // converges, first order at least
  for (int k = 0; k < 3; ++k) EXPECT_LT(mid[k], 0.5 * euler[k]) << "dt0 / " << (1 << k);
}

// Without the step control, the implicit coupling is first order in dt: the seed's ellipsoid
// (radius 0.6, dx = 1/8, Ca = 0.05, Re = 1) to t = 0.04 at dt = 4e-3 (1.5 times the explicit
// limit) to 5e-4; the max-norm node differences between successive dt halve with dt.
// Measured: 3.41e-3, 1.88e-3, 9.62e-4 (orders 0.86, 0.97).
TEST(TimeOrder, ImplicitCouplingIsFirstOrderInDt) {
  const auto d = test::implicit_ladder(
      {.max_level = 4, .radius = 0.6, .mesh_level = 3, .current_force_in_viscous = true}, NodeScheme::euler, 1e-4,
      {4e-3, 2e-3, 1e-3, 5e-4}, 0.04, "implicit Euler");
  EXPECT_GT(std::log2(d[0] / d[1]), 0.75);
  EXPECT_GT(std::log2(d[1] / d[2]), 0.9);
}

}  // namespace
}  // namespace capsflow::ibm
