// The flow's energy budget (fluid/energy.hpp, issue 32): kinetic energy and dissipation of
// an analytic field against their exact integrals (order 2, uniform and adaptive), the
// boundary work of a moving wall and of an inflow/outflow pair (exact for Couette, to the
// discretisation error for Poiseuille), and the time integral of a decaying vortex's budget
// (first order in dt with backward Euler, second with Crank-Nicolson).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fluid/energy.hpp"
#include "flow_sides.hpp"

namespace capsflow::fluid {
namespace {

using testing::all;
using testing::kPi;
using tree::Point;
using tree::Tree;

// u = (sin 2 pi x cos 2 pi y, -cos 2 pi x sin 2 pi y) on the periodic unit square, rho = 1,
// mu = 0.1: K = 1/4, Phi = mu |grad u|^2 = mu 4 pi^2 (|grad u|^2 has the mean 4 pi^2).
struct VortexErrors {
  double kinetic, dissipation;
};

VortexErrors vortex_errors(int level, bool adaptive) {
  Tree<2> t({.roots = {1, 1}, .periodic = {true, true}, .max_level = level + 1});
  t.refine_to([&](const tree::Box<2>& b) { return adaptive && b.lo[0] < 0.3 && b.lo[1] > 0.4 ? level + 1 : level; });
  const double mu = 0.1;
  NavierStokes<2> ns(t, {.Re = 1.0 / mu, .boundaries = all<2>(SideKind::periodic)});
  const double k = 2 * kPi;
  for (const auto c : t.leaves()) {
    const Point<2> x = t.center(c);
    ns.u(0)[c] = std::sin(k * x[0]) * std::cos(k * x[1]);
    ns.u(1)[c] = -std::cos(k * x[0]) * std::sin(k * x[1]);
  }
  const FlowEnergy e = flow_energy(ns);
  EXPECT_EQ(e.boundary_power, 0.0) << "periodic: no sides";
  return {std::abs(e.kinetic - 0.25) / 0.25, std::abs(e.dissipation - mu * k * k) / (mu * k * k)};
}

TEST(FlowEnergy, KineticEnergyAndDissipationAreSecondOrder) {
  for (const bool adaptive : {false, true}) {
    std::vector<double> kinetic, dissipation;
    for (int level = 4; level <= 7; ++level) {
      const VortexErrors e = vortex_errors(level, adaptive);
      kinetic.push_back(e.kinetic);
      dissipation.push_back(e.dissipation);
    }
    if (adaptive) testing::expect_orders_at_least("K, adaptive", kinetic, 1.6);
    else EXPECT_LT(kinetic.front(), 1e-14) << "the midpoint rule is exact for this field on a uniform periodic grid";
    testing::expect_orders_at_least(adaptive ? "Phi, adaptive" : "Phi, uniform", dissipation, 1.8);
    EXPECT_LT(dissipation.back(), 2e-3);
  }
}

// Plane Couette between a wall (y = 0) and a wall moving at U (y = 1), periodic in x: u = U y,
// so Phi = mu U^2 and the moving wall's work P_b = mu U^2, exactly (the boundary cells are exact for a
// linear field).
TEST(FlowEnergy, MovingWallWorkEqualsCouetteDissipation) {
  Tree<2> t({.roots = {1, 1}, .periodic = {true, false}, .max_level = 5});
  t.refine_to([](const tree::Box<2>& b) { return b.lo[1] < 0.5 ? 5 : 4; });
  auto sides = all<2>(SideKind::periodic);
  sides[2] = {.kind = SideKind::wall};
  sides[3] = {.kind = SideKind::moving_wall, .velocity = {1.5, 0.0}};
  const double mu = 0.2;
  NavierStokes<2> ns(t, {.Re = 1.0 / mu, .boundaries = sides});
  for (const auto c : t.leaves()) ns.u(0)[c] = 1.5 * t.center(c)[1];
  const FlowEnergy e = flow_energy(ns);
  EXPECT_NEAR(e.dissipation, mu * 1.5 * 1.5, 1e-13);
  EXPECT_NEAR(e.boundary_power, mu * 1.5 * 1.5, 1e-13);
  EXPECT_NEAR(e.kinetic, 0.5 * 1.5 * 1.5 / 3.0, 1e-3);  // int (U y)^2 / 2 = U^2 / 6, midpoint rule
}

// Steady plane Poiseuille flow, parabolic inflow at x_lo, outflow at x_hi (p = 0), walls at
// y = 0 and 1, Stokes: what the inflow's pressure and viscous stress put in is dissipated,
// P_b = Phi, to the discretisation error. Measured order 1.5 (1.8e-3, 6.3e-4, 2.2e-4 at
// 16, 32, 64 cells across): the solver's pressure has zero normal gradient at the inflow
// (Basilisk's condition where the velocity is given), so the face pressure there is the
// cell's, and the physical gradient -12 mu shows in a thin layer.
double poiseuille_imbalance(int level) {
  Tree<2> t({.roots = {2, 1}, .max_level = level});
  t.refine_to([level](const tree::Box<2>&) { return level; });
  auto sides = all<2>(SideKind::wall);
  sides[0] = {.kind = SideKind::inflow, .profile = InflowProfile::parabolic, .mean_velocity = 1.0};
  sides[1] = {.kind = SideKind::outflow};
  FlowOptions<2> o{.Re = 1.0, .stokes = true, .dt = 0.05, .boundaries = sides};
  o.projection.tolerance = o.viscous.tolerance = 1e-10;
  NavierStokes<2> ns(t, o);
  for (const auto c : t.leaves()) {  // start from the developed profile
    const double y = t.center(c)[1];
    ns.u(0)[c] = 6.0 * y * (1.0 - y);
  }
  for (int s = 0; s < 100; ++s) (void)ns.step();
  const FlowEnergy e = flow_energy(ns);
  // Exact: Phi = int mu (du/dy)^2 = 2 * 12 mu = 24 over the length 2; the pressure drop 12 mu L.
  EXPECT_NEAR(e.dissipation, 24.0, 24.0 * 0.05);
  return std::abs(e.boundary_power - e.dissipation) / e.dissipation;
}

TEST(FlowEnergy, InflowWorkEqualsPoiseuilleDissipation) {
  std::vector<double> imbalance;
  for (int level = 4; level <= 6; ++level) imbalance.push_back(poiseuille_imbalance(level));
  testing::expect_orders_at_least("Poiseuille P_b - Phi", imbalance, 1.4);
  EXPECT_LT(imbalance.back(), 1e-3);
}

// The decaying vortex (periodic, from the field above): K(0) - K(t) = int_0^t Phi dt. The
// residual of that balance, with Phi integrated by the trapezoidal rule, falls with dt at
// the viscous scheme's order.
// The budget's relative residual, K(start) - K(0.1) - int Phi dt over (K(start) - K(0.1)),
// of the vortex decaying on the periodic unit square (plus `drift` along x), around `solid`
// if given. With a solid the budget starts after the first step, whose projection removes
// the part of the initial field that crosses the wall.
double budget_residual(double dt, bool crank_nicolson, const geometry::SolidPtr& solid = nullptr, double drift = 0.0,
                       const NavierStokes<2>::Properties& properties = {}) {
  Tree<2> t({.roots = {1, 1}, .periodic = {true, true}, .max_level = 5});
  t.refine_to([](const tree::Box<2>&) { return 5; });
  FlowOptions<2> o{.Re = 10.0, .stokes = true, .dt = dt, .crank_nicolson = crank_nicolson,
                   .boundaries = all<2>(SideKind::periodic)};
  o.projection.tolerance = o.viscous.tolerance = 1e-11;
  NavierStokes<2> ns(t, o);
  const double k = 2 * kPi;
  for (const auto c : t.leaves()) {
    const Point<2> x = t.center(c);
    ns.u(0)[c] = std::sin(k * x[0]) * std::cos(k * x[1]) + drift;
    ns.u(1)[c] = -std::cos(k * x[0]) * std::sin(k * x[1]);
  }
  if (properties) ns.set_properties(properties);
  if (solid) {
    ns.set_solid(solid);
    (void)ns.step();
  }
  FlowEnergy e = flow_energy(ns);
  const double k0 = e.kinetic;
  double dissipated = 0.0;
  while (ns.time() < 0.1 - 1e-12) {
    const double before = e.dissipation;
    (void)ns.step();
    e = flow_energy(ns);
    EXPECT_GT(e.dissipation, 0.0);
    dissipated += 0.5 * ns.last_dt() * (before + e.dissipation);
  }
  return std::abs(k0 - e.kinetic - dissipated) / (k0 - e.kinetic);
}

// With an embedded cylinder in the square (its no-slip walls): the kinetic energy of the
// cells' fluid parts, the dissipation through the open parts of the faces and the walls'
// share (minus u . the walls' flux). Measured relative residuals at dt = 0.01, 0.005,
// 0.0025: backward Euler 1.0e-1, 3.9e-2, 1.1e-2 (orders 1.4, 1.8); Crank-Nicolson 8.1e-2,
// 3.1e-2, 7.5e-3 (1.4, 2.0).
TEST(FlowEnergy, BudgetAroundAnEmbeddedCylinderClosesAtTheSchemesOrder) {
  const auto cylinder = geometry::sphere({0.53, 0.47, 0.0}, 0.17);
  std::vector<double> euler, cn;
  for (const double dt : {0.01, 0.005, 0.0025}) {
    euler.push_back(budget_residual(dt, false, cylinder, 0.3));
    cn.push_back(budget_residual(dt, true, cylinder, 0.3));
  }
  for (std::size_t i = 0; i < euler.size(); ++i)
    std::printf("embedded cylinder budget residual: BE %.3e, CN %.3e\n", euler[i], cn[i]);
  testing::expect_orders_at_least("backward Euler budget, embedded cylinder", euler, 0.9);
  testing::expect_orders_at_least("Crank-Nicolson budget, embedded cylinder", cn, 1.3);
  EXPECT_LT(euler.back(), 2e-2);
  EXPECT_LT(cn.back(), 1e-2);
}

// The same with a heavier layer beside the cylinder (density 3 where y > 0.6, each cell's
// mean; mu = 0.1 everywhere): K = int rho |u|^2 / 2 over the cells' fluid parts, the
// viscous solves' cell term rho / dt per cell and the projection's faces 1/rho times the
// fractions. Measured relative residuals at dt = 0.01, 0.005, 0.0025: backward Euler 6.4e-2,
// 2.3e-2, 5.3e-3 (orders 1.5, 2.1); Crank-Nicolson 6.9e-2, 2.5e-2, 5.5e-3 (1.5, 2.2), a
// little below the one density's.
TEST(FlowEnergy, BudgetWithTwoDensitiesAroundAnEmbeddedCylinderClosesAtTheSchemesOrder) {
  const auto cylinder = geometry::sphere({0.53, 0.47, 0.0}, 0.17);
  const NavierStokes<2>::Properties layers = [](const Tree<2>& t, std::span<double> rho, std::span<double> mu) {
    for (const auto c : t.leaves()) {
      const tree::Box<2> b = t.box(c);
      const double above = std::clamp((b.hi[1] - 0.6) / (b.hi[1] - b.lo[1]), 0.0, 1.0);
      rho[c] = 1.0 + 2.0 * above;
      mu[c] = 0.1;
    }
  };
  std::vector<double> euler, cn;
  for (const double dt : {0.01, 0.005, 0.0025}) {
    euler.push_back(budget_residual(dt, false, cylinder, 0.3, layers));
    cn.push_back(budget_residual(dt, true, cylinder, 0.3, layers));
  }
  for (std::size_t i = 0; i < euler.size(); ++i)
    std::printf("two densities, embedded cylinder budget residual: BE %.3e, CN %.3e\n", euler[i], cn[i]);
  testing::expect_orders_at_least("backward Euler budget, two densities", euler, 0.9);
  testing::expect_orders_at_least("Crank-Nicolson budget, two densities", cn, 1.3);
  EXPECT_LT(euler.back(), 2e-2);
  EXPECT_LT(cn.back(), 1e-2);
}

TEST(FlowEnergy, DecayingVortexBudgetClosesAtTheSchemesOrder) {
  std::vector<double> euler, cn;
  for (const double dt : {0.01, 0.005, 0.0025}) {
    euler.push_back(budget_residual(dt, false));
    cn.push_back(budget_residual(dt, true));
  }
  testing::expect_orders_at_least("backward Euler budget", euler, 0.9);
  testing::expect_orders_at_least("Crank-Nicolson budget", cn, 1.8);
}

}  // namespace
}  // namespace capsflow::fluid
