// A density that varies beside embedded walls (an inner fluid of another density in a tube):
// the viscous solves' cell term rho / dt per cell, the projection's faces 1/rho times the
// fluid fractions. Checked against a one-dimensional reference for a start-up flow between
// walls off the grid with two layers of density, and against the solver without walls when
// the solid cuts no cell.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fluid/navier_stokes.hpp"
#include "flow_sides.hpp"

namespace capsflow::fluid {
namespace {

using tree::Index;
using tree::Point;
using tree::Tree;

// Between walls at y = a and b (off the grid), rho = rho1 below y0 and rho2 above, mu = 1,
// driven from rest by the force f = 1 per unit volume along x: rho u_t = u_yy + 1. The
// solver's schedule for such a parallel flow (no pressure, g = f / rho constant after the
// first step): u^1 = dt / rho, then backward Euler, rho (u^(n+1) - u^n) / dt = u_yy^(n+1) + 1.
// The reference takes the same schedule on n cells of [a, b] (each cell's mean density, no
// slip at the walls), so what remains is the solver's error in space.
struct TwoDensityStartup {
  double a = 0.1234, b = 0.8611, y0 = 0.47, rho1 = 1.0, rho2 = 3.0, dt = 2e-3;
  int steps = 50;

  double mean_density(double lo, double hi) const {
    const double below = std::clamp((y0 - lo) / (hi - lo), 0.0, 1.0);
    return below * rho1 + (1.0 - below) * rho2;
  }

  // The velocity at the n cell centres of [a, b] after `steps` steps (Thomas algorithm).
  std::vector<double> reference(int n) const {
    const double h = (b - a) / n;
    std::vector<double> rho(n), u(n), lower(n), diag(n), upper(n), rhs(n);
    for (int i = 0; i < n; ++i) {
      rho[i] = mean_density(a + i * h, a + (i + 1) * h);
      u[i] = dt / rho[i];
    }
    for (int step = 1; step < steps; ++step) {
      for (int i = 0; i < n; ++i) {
        const double wall = (i == 0 || i == n - 1) ? 1.0 : 0.0;  // the wall half a cell away
        lower[i] = upper[i] = -1.0 / (h * h);
        diag[i] = rho[i] / dt + (2.0 + wall) / (h * h);
        rhs[i] = rho[i] / dt * u[i] + 1.0;
      }
      for (int i = 1; i < n; ++i) {
        const double m = lower[i] / diag[i - 1];
        diag[i] -= m * upper[i - 1];
        rhs[i] -= m * rhs[i - 1];
      }
      u[n - 1] = rhs[n - 1] / diag[n - 1];
      for (int i = n - 2; i >= 0; --i) u[i] = (rhs[i] - upper[i] * u[i + 1]) / diag[i];
    }
    return u;
  }

  // The reference at y, linear between its centres and the walls (and beyond a wall: the
  // field's extension, which a cut cell whose centre lies in the solid holds).
  static double at(const std::vector<double>& u, double a, double b, double y) {
    const int n = static_cast<int>(u.size());
    const double h = (b - a) / n;
    std::vector<double> ys{a}, vs{0.0};
    for (int i = 0; i < n; ++i) {
      ys.push_back(a + (i + 0.5) * h);
      vs.push_back(u[static_cast<std::size_t>(i)]);
    }
    ys.push_back(b);
    vs.push_back(0.0);
    std::size_t k = 1;
    while (k + 1 < ys.size() - 1 && ys[k] < y) ++k;
    if (y > ys[ys.size() - 2]) k = ys.size() - 1;
    const double w = (y - ys[k - 1]) / (ys[k] - ys[k - 1]);
    return (1.0 - w) * vs[k - 1] + w * vs[k];
  }

  NavierStokes<2>::Properties properties() const {
    return [*this](const Tree<2>& t, std::span<double> rho, std::span<double> mu) {
      for (const Index c : t.leaves()) {
        const tree::Box<2> box = t.box(c);
        rho[c] = mean_density(box.lo[1], box.hi[1]);
        mu[c] = 1.0;
      }
    };
  }
};

struct Errors {
  double max = 0.0, l1 = 0.0;
};

Errors startup_errors(const TwoDensityStartup& s, int level, bool stokes, const std::vector<double>& reference) {
  Tree<2> t({.roots = {1, 1}, .periodic = {true, false}, .max_level = level});
  t.refine_to([level](const tree::Box<2>&) { return level; });
  std::array<SideFlow<2>, 4> sides = testing::all<2>(SideKind::wall);
  sides[0] = sides[1] = {.kind = SideKind::periodic};
  FlowOptions<2> o{.Re = 1.0, .stokes = stokes, .dt = s.dt, .boundaries = sides};
  o.projection.tolerance = o.viscous.tolerance = 1e-11;
  o.projection.max_cycles = o.viscous.max_cycles = 100;
  NavierStokes<2> ns(t, o);
  ns.set_solid(geometry::unite({geometry::box({-1.0, -1.0, -1.0}, {2.0, s.a, 1.0}),
                                geometry::box({-1.0, s.b, -1.0}, {2.0, 2.0, 1.0})}));
  ns.set_properties(s.properties());
  ns.set_face_force([](const Tree<2>&, FaceField<2>& f) { std::fill(f[0].begin(), f[0].end(), 1.0); });
  for (int step = 0; step < s.steps; ++step) EXPECT_TRUE(ns.step().converged) << "step " << step;
  Errors e;
  const auto volume = ns.embedded()->volume();
  for (const Index c : t.leaves()) {
    const auto k = static_cast<std::size_t>(c);
    if (!(volume[k] > 0.0)) continue;
    const double h = t.cell_size(t.level_of(c));
    const double err = std::abs(ns.u(0)[c] - TwoDensityStartup::at(reference, s.a, s.b, t.center(c)[1]));
    e.max = std::max(e.max, std::max(err, std::abs(ns.u(1)[c])));
    e.l1 += err * volume[k] * h * h;
  }
  EXPECT_LT(ns.max_divergence(), 1e-9);
  return e;
}

// Measured (Stokes and Navier-Stokes alike, u . grad u = 0): max 1.93e-4, 4.40e-5, 1.56e-5
// and L1 6.79e-5, 1.83e-5, 6.65e-6 at levels 5-7 (L1 orders 1.89, 1.46), against a density
// effect of 1.9e-2; with one density (rho2 = rho1) max 1.94e-4, 4.48e-5, 1.57e-5 and L1
// 9.5e-5, 2.5e-5, 9.0e-6. So the density jump adds no error: what remains is the walls'
// (EmbeddedFlow.PoiseuilleBetweenWallsOffTheGrid, orders near 1.6).
TEST(EmbeddedDensity, TwoDensityStartupBetweenWallsOffTheGrid) {
  const TwoDensityStartup s;
  const std::vector<double> reference = s.reference(4096);
  TwoDensityStartup one = s;
  one.rho2 = s.rho1;
  const std::vector<double> one_density = one.reference(4096);
  double contrast = 0.0;  // how far the upper layer's density moves the flow
  for (std::size_t i = 0; i < reference.size(); ++i) contrast = std::max(contrast, std::abs(reference[i] - one_density[i]));
  for (const bool stokes : {true, false}) {
    std::vector<Errors> e;
    for (int level = 5; level <= 7; ++level) {
      e.push_back(startup_errors(s, level, stokes, reference));
      std::printf("%s, level %d: max %.3e, L1 %.3e (the density's effect: %.3e)\n", stokes ? "Stokes" : "Navier-Stokes",
                  level, e.back().max, e.back().l1, contrast);
    }
    std::vector<double> l1;
    for (std::size_t k = 0; k < e.size(); ++k) {
      l1.push_back(e[k].l1);
      if (k == 0) continue;
      std::printf("  orders %.2f (max) %.2f (L1)\n", std::log2(e[k - 1].max / e[k].max), std::log2(e[k - 1].l1 / e[k].l1));
      EXPECT_GE(std::log2(e[k - 1].max / e[k].max), 1.0);
      EXPECT_GE(std::log2(e[k - 1].l1 / e[k].l1), 1.0);
    }
    std::printf("  fitted L1 order %.2f\n", testing::fitted_order(l1));
    EXPECT_GE(testing::fitted_order(l1), 1.5);
    EXPECT_LT(e.back().max, 2e-3 * contrast);
  }
}

// A closed box, the force sin(2 pi y) along x driving a shear flow past a disc three times
// as heavy and twice as viscous (its pressure gradient is 1/rho times the face's). The same flow with an embedded solid
// that cuts no cell (the fluid's code path with walls: the fractions' arrays, the density
// per cell) must be the solver's without walls, on an adapted tree (parents, halos).
std::array<std::vector<double>, 3> flow_around_a_heavy_disc(bool embedded) {
  Tree<2> t({.roots = {1, 1}, .max_level = 6});
  t.refine_to([](const tree::Box<2>& b) {
    const double x = 0.5 * (b.lo[0] + b.hi[0]) - 0.5, y = 0.5 * (b.lo[1] + b.hi[1]) - 0.45;
    return std::hypot(x, y) < 0.3 ? 6 : 5;
  });
  FlowOptions<2> o{.Re = 10.0, .dt = 0.01, .boundaries = testing::all<2>(SideKind::wall)};
  o.projection.tolerance = o.viscous.tolerance = 1e-11;
  o.projection.max_cycles = o.viscous.max_cycles = 100;
  NavierStokes<2> ns(t, o);
  if (embedded) ns.set_solid(geometry::sphere({5.0, 5.0, 0.0}, 0.1));
  ns.set_properties([](const Tree<2>& tr, std::span<double> rho, std::span<double> mu) {
    for (const Index c : tr.leaves()) {
      const tree::Box<2> b = tr.box(c);
      double inside = 0.0;  // the disc's share of the cell, by 8 x 8 samples
      for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) {
          const double x = b.lo[0] + (i + 0.5) / 8 * (b.hi[0] - b.lo[0]), y = b.lo[1] + (j + 0.5) / 8 * (b.hi[1] - b.lo[1]);
          inside += std::hypot(x - 0.5, y - 0.45) < 0.2 ? 1.0 / 64 : 0.0;
        }
      rho[c] = 1.0 + 2.0 * inside;
      mu[c] = 0.1 / (inside / 2.0 + (1.0 - inside));
    }
  });
  ns.set_face_force([](const Tree<2>& tr, FaceField<2>& f) {
    for_each_face<2>(tr, [&](int d, Index lo, Index hi, double, const tree::Level<2>&) {
      f[d][hi] = d == 0 ? std::sin(2.0 * testing::kPi * tr.center(lo)[1]) : 0.0;  // y is the lower cell's
    });
  });
  for (int step = 0; step < 10; ++step) EXPECT_TRUE(ns.step().converged) << "step " << step;
  std::array<std::vector<double>, 3> out;
  for (const Index c : t.leaves()) {
    out[0].push_back(ns.u(0)[c]);
    out[1].push_back(ns.u(1)[c]);
    out[2].push_back(t.values(ns.pressure())[c]);
  }
  if (embedded) {
    EXPECT_EQ(ns.embedded()->volume().size(), static_cast<std::size_t>(t.num_cells()));
  }
  return out;
}

TEST(EmbeddedDensity, ASolidThatCutsNoCellLeavesTheFlowAsWithout) {
  const auto plain = flow_around_a_heavy_disc(false), walls = flow_around_a_heavy_disc(true);
  ASSERT_EQ(plain[0].size(), walls[0].size());
  double speed = 0.0, diff = 0.0, p_range = 0.0, p_diff = 0.0;
  double p_mean[2] = {0.0, 0.0};  // the pressure up to its constant
  for (std::size_t k = 0; k < plain[2].size(); ++k) {
    p_mean[0] += plain[2][k] / static_cast<double>(plain[2].size());
    p_mean[1] += walls[2][k] / static_cast<double>(plain[2].size());
  }
  for (std::size_t k = 0; k < plain[0].size(); ++k) {
    for (int d = 0; d < 2; ++d) {
      speed = std::max(speed, std::abs(plain[d][k]));
      diff = std::max(diff, std::abs(plain[d][k] - walls[d][k]));
    }
    p_range = std::max(p_range, std::abs(plain[2][k] - p_mean[0]));
    p_diff = std::max(p_diff, std::abs((plain[2][k] - p_mean[0]) - (walls[2][k] - p_mean[1])));
  }
  std::printf("max |u| %.3e, difference %.1e; pressure %.3e, difference %.1e\n", speed, diff, p_range, p_diff);
  EXPECT_GT(speed, 1e-3);
  EXPECT_LT(diff, 1e-8 * speed);
  EXPECT_LT(p_diff, 1e-8 * p_range);
}

}  // namespace
}  // namespace capsflow::fluid
