// The flow solver against exact solutions: Taylor-Green decay (order in space), plane
// Couette (exact), a body force balanced by pressure (zero velocity), divergence after
// projection on an adaptive grid.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "fluid/navier_stokes.hpp"
#include "flow_sides.hpp"

namespace capsflow::fluid {
namespace {

using tree::Point;
using tree::Tree;

using testing::all;
using testing::kPi;

Tree<2> unit_square(int level, bool periodic_x, bool periodic_y) {
  Tree<2> t({.roots = {1, 1}, .periodic = {periodic_x, periodic_y}, .max_level = level});
  t.refine_to([level](const tree::Box<2>&) { return level; });
  return t;
}

// 2D Taylor-Green vortex, k = 2 pi on the unit periodic square; velocity decays as
// exp(-2 nu k^2 t). Crank-Nicolson viscosity and dt ~ h keep the time error at O(h^2).
double taylor_green_error(int level, double t_end) {
  Tree<2> t = unit_square(level, true, true);
  const double nu = 0.01, k = 2 * kPi;
  FlowOptions<2> o{.Re = 1.0 / nu, .dt = 0.25 / (1 << level), .crank_nicolson = true,
                   .boundaries = all<2>(SideKind::periodic)};
  o.projection.tolerance = o.viscous.tolerance = 1e-9;
  NavierStokes<2> ns(t, o);
  for (const auto c : t.leaves()) {
    const Point<2> x = t.center(c);
    ns.u(0)[c] = -std::cos(k * x[0]) * std::sin(k * x[1]);
    ns.u(1)[c] = std::sin(k * x[0]) * std::cos(k * x[1]);
  }
  const int steps = static_cast<int>(std::lround(t_end / o.dt));
  for (int s = 0; s < steps; ++s) {
    const auto st = ns.step();
    EXPECT_TRUE(st.converged);
  }
  const double decay = std::exp(-2 * nu * k * k * ns.time());
  double worst = 0.0;
  for (const auto c : t.leaves()) {
    const Point<2> x = t.center(c);
    worst = std::max({worst, std::abs(ns.u(0)[c] + std::cos(k * x[0]) * std::sin(k * x[1]) * decay),
                      std::abs(ns.u(1)[c] - std::sin(k * x[0]) * std::cos(k * x[1]) * decay)});
  }
  return worst;
}

TEST(FlowExact, TaylorGreenSecondOrderInSpace) {
  std::vector<double> err;
  for (int level = 4; level <= 6; ++level) err.push_back(taylor_green_error(level, 0.5));
  testing::expect_orders_at_least("Taylor-Green", err, 1.8);
  EXPECT_LT(err.back(), 5e-3);
}

// Plane Couette between a wall (y = 0) and a wall moving at U (y = 1), periodic in x:
// u = U y is reproduced exactly (the discrete operators are exact for linear fields).
TEST(FlowExact, CouetteExactInStokesAndNavierStokes) {
  for (const bool stokes : {true, false}) {
    Tree<2> t = unit_square(5, true, false);
    auto sides = all<2>(SideKind::periodic);
    sides[2] = {.kind = SideKind::wall};
    sides[3] = {.kind = SideKind::moving_wall, .velocity = {1.5, 0.0}};
    NavierStokes<2> ns(t, {.Re = 10, .stokes = stokes, .dt = 0.01, .boundaries = sides});
    for (const auto c : t.leaves()) ns.u(0)[c] = 1.5 * t.center(c)[1];
    for (int s = 0; s < 20; ++s) (void)ns.step();
    for (const auto c : t.leaves()) {
      ASSERT_NEAR(ns.u(0)[c], 1.5 * t.center(c)[1], 1e-12);
      ASSERT_NEAR(ns.u(1)[c], 0.0, 1e-12);
    }
  }
}

// Started from rest, Couette flow develops to the linear profile; advection on and off
// give the same history, since (u.grad)u = 0 in this flow.
TEST(FlowExact, CouetteStartupSameWithAndWithoutAdvection) {
  std::vector<double> profile[2];
  for (const bool stokes : {true, false}) {
    Tree<2> t = unit_square(5, true, false);
    auto sides = all<2>(SideKind::periodic);
    sides[2] = {.kind = SideKind::wall};
    sides[3] = {.kind = SideKind::moving_wall, .velocity = {1.0, 0.0}};
    FlowOptions<2> o{.Re = 1, .stokes = stokes, .dt = 0.02, .boundaries = sides};
    o.projection.tolerance = o.viscous.tolerance = 1e-10;
    NavierStokes<2> ns(t, o);
    for (int s = 0; s < 100; ++s) (void)ns.step();
    for (const auto c : t.leaves()) profile[stokes].push_back(ns.u(0)[c]);
    double worst = 0.0;
    for (const auto c : t.leaves()) worst = std::max(worst, std::abs(ns.u(0)[c] - t.center(c)[1]));
    EXPECT_LT(worst, 1e-4) << "t = 2 is about 20 viscous times: steady";
  }
  // Equal to the solvers' tolerance (1e-10 in velocity): the NS path projects twice a step.
  for (std::size_t i = 0; i < profile[0].size(); ++i) ASSERT_NEAR(profile[0][i], profile[1][i], 1e-10);
}

// A face force that is the discrete gradient of a cell field phi (same face-gradient rule
// as the pressure: fine faces from same-level values with quadratic halos, coarse faces
// the mean of the fine ones) is balanced by the pressure: the fluid stays at rest, to
// the solver tolerance, in Stokes and Navier-Stokes mode, on an adaptive grid with walls.
TEST(FlowExact, GradientForceGivesNoMotion) {
  for (const bool stokes : {true, false}) {
    Tree<2> t({.roots = {1, 1}, .max_level = 6});
    t.refine_to([](const tree::Box<2>& b) { return b.lo[0] < 0.4 && b.lo[1] < 0.5 ? 6 : 4; });
    FlowOptions<2> o{.Re = 1, .stokes = stokes, .dt = 0.01, .boundaries = all<2>(SideKind::wall)};
    o.projection.tolerance = 1e-10;
    NavierStokes<2> ns(t, o);
    std::vector<double> phi(t.num_cells(), 0.0);
    for (const auto c : t.leaves()) {
      const Point<2> x = t.center(c);
      phi[c] = std::sin(3 * x[0]) * std::exp(x[1]) + 4 * x[1];
    }
    t.sync(phi, tree::BoundaryConditions<2>::all(tree::BcKind::neumann), tree::Prolongation::quadratic);
    ns.set_face_force([&](const Tree<2>& tr, FaceField<2>& f) {
      for_each_face<2>(tr, [&](int d, Index lo, Index hi, double h, const tree::Level<2>&) {
        f[d][hi] = (phi[hi] - phi[lo]) / h;
      });
      restrict_faces<2>(tr, f);
    });
    double worst = 0.0;
    for (int s = 0; s < 10; ++s) {
      const auto st = ns.step();
      EXPECT_TRUE(st.converged);
      for (const auto c : t.leaves()) worst = std::max({worst, std::abs(ns.u(0)[c]), std::abs(ns.u(1)[c])});
    }
    EXPECT_LT(worst, 1e-10) << (stokes ? "Stokes" : "Navier-Stokes");
    // The pressure is phi (up to a constant).
    const double shift = ns.p()[t.leaves()[0]] - phi[t.leaves()[0]];
    for (const auto c : t.leaves()) ASSERT_NEAR(ns.p()[c] - shift, phi[c], 1e-8);
  }
}

// After projection the face velocity is divergence-free to the solver tolerance, and its
// divergence sums to zero over an adaptive periodic domain to round-off.
TEST(FlowExact, ProjectionDivergenceOnAdaptiveGrid) {
  Tree<2> t({.roots = {1, 1}, .periodic = {true, true}, .max_level = 7});
  t.refine_to([](const tree::Box<2>& b) {
    const double cx = std::clamp(0.5, b.lo[0], b.hi[0]) - 0.5, cy = std::clamp(0.5, b.lo[1], b.hi[1]) - 0.5;
    return cx * cx + cy * cy < 0.04 ? 7 : 4;
  });
  FlowOptions<2> o{.Re = 100, .dt = 0.002, .boundaries = all<2>(SideKind::periodic)};
  o.projection.tolerance = 1e-8;
  NavierStokes<2> ns(t, o);
  for (const auto c : t.leaves()) {
    const Point<2> x = t.center(c);
    ns.u(0)[c] = std::sin(2 * kPi * x[1]) + 0.3 * std::cos(6 * x[0]);  // not divergence-free
    ns.u(1)[c] = std::cos(2 * kPi * x[0]) + 0.2 * x[1] * (1 - x[1]);
  }
  (void)ns.step();
  EXPECT_LT(ns.max_divergence() * 0.002, 1e-8);  // |div uf| dt below the tolerance
  std::vector<double> div(t.num_cells());
  divergence<2>(t, ns.face_velocity(), div);
  double sum = 0.0, scale = 0.0;
  for (const auto c : t.leaves()) {
    const double v = std::pow(t.cell_size(t.level_of(c)), 2);
    sum += div[c] * v;
    scale += std::abs(div[c]) * v;
  }
  EXPECT_LT(std::abs(sum), 1e-15 + 1e-12 * scale);
}

}  // namespace
}  // namespace capsflow::fluid

namespace capsflow::fluid {
namespace {

// Ethier & Steinman (1994): an exact unsteady 3D Navier-Stokes solution; on [-1, 1]^3 with
// its velocity prescribed on every side. Backward-Euler viscosity with dt = h^2/2 keeps
// the time error O(h^2). (Crank-Nicolson is not L-stable: with nu dt / h^2 ~ 1 it lets
// the stiffest modes oscillate, and the projection splitting then amplifies them.)
struct EthierSteinman {
  double a = kPi / 4, d = kPi / 2, nu = 1.0;
  double u(const tree::Point<3>& x, int c, double t) const {
    const double decay = std::exp(-nu * d * d * t);
    const int i = c, j = (c + 1) % 3, k = (c + 2) % 3;  // cyclic in (x, y, z)
    return -a * (std::exp(a * x[i]) * std::sin(a * x[j] + d * x[k]) + std::exp(a * x[k]) * std::cos(a * x[i] + d * x[j])) * decay;
  }
};

double ethier_steinman_error(int level) {
  tree::Tree<3> t({.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .max_level = level});
  t.refine_to([level](const tree::Box<3>&) { return level; });
  const EthierSteinman es;
  std::array<SideFlow<3>, 6> sides{};
  for (auto& s : sides) s = {.kind = SideKind::prescribed, .prescribed = [es](const tree::Point<3>& x, int c, double time) { return es.u(x, c, time); }};
  const double h = t.cell_size(level);
  FlowOptions<3> o{.Re = 1.0 / es.nu, .dt = 0.5 * h * h, .boundaries = sides};
  o.projection.tolerance = o.viscous.tolerance = 1e-9;
  NavierStokes<3> ns(t, o);
  for (const auto c : t.leaves())
    for (int k = 0; k < 3; ++k) ns.u(k)[c] = es.u(t.center(c), k, 0.0);
  while (ns.time() < 0.25 - 1e-12) (void)ns.step();
  double worst = 0.0;
  for (const auto c : t.leaves())
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(ns.u(k)[c] - es.u(t.center(c), k, ns.time())));
  return worst;
}

TEST(FlowExact, EthierSteinmanSecondOrderInSpace) {
  std::vector<double> err;
  for (int level = 3; level <= 5; ++level) err.push_back(ethier_steinman_error(level));
  testing::expect_orders_at_least("Ethier-Steinman", err, 1.8);
}

}  // namespace
}  // namespace capsflow::fluid

namespace capsflow::fluid {
namespace {

// Plane Poiseuille flow driven by a uniform force G between walls y = 0 and y = 1 (periodic
// in x): u = G Re y (1 - y) / 2. The cell-centred boundary cell is second order for this
// quadratic profile (not exact, unlike Couette), so the steady error falls as h^2, the
// same with and without advection ((u.grad)u = 0 here).
double poiseuille_error(int level, bool stokes) {
  tree::Tree<2> t({.roots = {1, 1}, .periodic = {true, false}, .max_level = level});
  t.refine_to([level](const tree::Box<2>&) { return level; });
  std::array<SideFlow<2>, 4> sides{};
  sides[0].kind = sides[1].kind = SideKind::periodic;
  const double Re = 2.0, G = 1.0;
  FlowOptions<2> o{.Re = Re, .stokes = stokes, .dt = 0.02, .cfl = 0.5, .boundaries = sides};
  o.projection.tolerance = o.viscous.tolerance = 1e-10;
  NavierStokes<2> ns(t, o);
  ns.set_face_force([&](const tree::Tree<2>& tr, FaceField<2>& f) {
    for_each_face<2>(tr, [&](int d, Index, Index hi, double, const tree::Level<2>&) { f[d][hi] = d == 0 ? G : 0.0; });
  });
  while (ns.time() < 4.0) (void)ns.step();  // 8 viscous times Re/pi^2: steady to ~1e-10
  double worst = 0.0;
  for (const auto c : t.leaves()) {
    const double y = t.center(c)[1];
    worst = std::max({worst, std::abs(ns.u(0)[c] - G * Re * y * (1 - y) / 2), std::abs(ns.u(1)[c])});
  }
  return worst;
}

TEST(FlowExact, PoiseuilleSecondOrderStokesAndNavierStokes) {
  for (const bool stokes : {true, false}) {
    std::vector<double> err;
    for (int level = 3; level <= 5; ++level) err.push_back(poiseuille_error(level, stokes));
    for (std::size_t i = 1; i < err.size(); ++i) EXPECT_NEAR(std::log2(err[i - 1] / err[i]), 2.0, 0.1);
    EXPECT_LT(err.back(), 1e-3);
  }
  EXPECT_NEAR(poiseuille_error(4, true), poiseuille_error(4, false), 1e-9);
}

// A shear force that changes in time, f = (cos(w t) sin(k y), 0) on the periodic unit
// square (Stokes, nu = 1): u = (a(t) sin(k y), 0) exactly, with a' = -m a + cos(w t),
// a(0) = 0, and m = (4/h^2) sin^2(k h/2) the discrete Laplacian's eigenvalue, so the error is
// the time stepping's alone. The force is evaluated at t^n + dt/2. Crank-Nicolson is second
// order: its explicit half acts on u^n (it acted on u^n + dt g, a first-order error of
// dt/2 div(mu grad g) per step: order 1.0 and a 37% error at dt = 0.02 before the fix,
// issue 17), backward Euler first.
double forced_shear_error(double dt, bool crank_nicolson, bool current_force) {
  const int level = 4;
  Tree<2> t = unit_square(level, true, true);
  const double k = 2 * kPi, w = 3.0, h = 1.0 / (1 << level);
  FlowOptions<2> o{.Re = 1.0, .stokes = true, .dt = dt, .crank_nicolson = crank_nicolson,
                   .current_force_in_viscous = current_force, .boundaries = all<2>(SideKind::periodic)};
  o.projection.tolerance = o.viscous.tolerance = 1e-12;
  NavierStokes<2> ns(t, o);
  ns.set_face_force([&](const Tree<2>& tree, FaceField<2>& f) {
    const double amplitude = std::cos(w * (ns.time() + 0.5 * dt));
    for (const auto c : tree.leaves()) f[0][c] = amplitude * std::sin(k * tree.center(c)[1]);
  });
  const double t_end = 1.0;
  const int steps = static_cast<int>(std::lround(t_end / dt));
  for (int s = 0; s < steps; ++s) (void)ns.step();
  const double m = 4.0 / (h * h) * std::pow(std::sin(0.5 * k * h), 2);
  const double a = (m * std::cos(w * t_end) + w * std::sin(w * t_end) - m * std::exp(-m * t_end)) / (m * m + w * w);
  double err = 0.0;
  for (const auto c : t.leaves()) err = std::max(err, std::abs(ns.u(0)[c] - a * std::sin(k * t.center(c)[1])));
  return err / std::abs(a);
}

TEST(FlowExact, TimeDependentForceCrankNicolsonSecondOrder) {
  double errors[2] = {};
  for (const bool current : {false, true}) {
    double cn[3], be[3];
    for (int i = 0; i < 3; ++i) {
      cn[i] = forced_shear_error(0.02 / (1 << i), true, current);
      be[i] = forced_shear_error(0.02 / (1 << i), false, current);
    }
    std::printf("current force %d: Crank-Nicolson %.2e %.2e %.2e (orders %.2f %.2f), backward Euler %.2e %.2e %.2e "
                "(orders %.2f %.2f)\n",
                current, cn[0], cn[1], cn[2], std::log2(cn[0] / cn[1]), std::log2(cn[1] / cn[2]), be[0], be[1], be[2],
                std::log2(be[0] / be[1]), std::log2(be[1] / be[2]));
    EXPECT_GT(std::log2(cn[0] / cn[1]), 1.8);
    EXPECT_GT(std::log2(cn[1] / cn[2]), 1.8);
    // With the last step's force in the viscous solve, backward Euler's error stalls (1.5e-3
    // at dt = 0.01 and 0.005): the one-step lag of the force is an error of its own.
    if (current) {
      EXPECT_NEAR(std::log2(be[1] / be[2]), 1.0, 0.2);
    }
    errors[current ? 1 : 0] = cn[2];
  }
  // The lag costs Crank-Nicolson a factor 13 (3.6e-4 against 2.7e-5 at dt = 0.005).
  EXPECT_LT(errors[1], errors[0] / 5);
}

}  // namespace
}  // namespace capsflow::fluid
