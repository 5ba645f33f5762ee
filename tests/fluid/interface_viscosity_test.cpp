// A viscosity jump that the flow stretches as well as shears: the two-layer Stokes flow under
// a lid moving as cos(k x), exact, against the harmonic face rule (flow_properties.hpp), which
// the two-layer Poiseuille flow (flow_properties_test.cpp) shows second order for a shear
// across the interface.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>
#include <vector>

#include "flow_sides.hpp"
#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {
namespace {

using tree::Point;
using tree::Tree;

using testing::all;
using testing::kPi;

// Stokes flow in a channel periodic in x, walls at y = 0 (at rest) and y = 1 (tangential
// velocity U cos(k x), k = 2 pi), viscosity mu1 below y0 and mu2 above. With the stream
// function psi = f(y) cos(k x) (u = f' cos kx, v = k f sin kx) each layer has
//   f = (A + B y) cosh(k y) + (C + D y) sinh(k y),
// the walls give f(0) = f'(0) = 0, f(1) = 0, f'(1) = U, and the interface continuity of f,
// f', the shear stress mu (f'' + k^2 f) and the normal stress mu (3 k^2 f' - f''') (the
// pressure from the x momentum, p = mu (f''' - k^2 f') sin(kx) / k).
struct LidModes {
  double y0 = 0.4, mu1 = 1.0, mu2 = 4.0, U = 1.0;
  double k = 2.0 * kPi;
  Eigen::Matrix<double, 8, 1> c;  // A, B, C, D below, then above

  // Row r: d^r/dy^r of the four basis functions cosh(ky), y cosh(ky), sinh(ky), y sinh(ky) at y.
  Eigen::Matrix4d basis(double y) const {
    const double ch = std::cosh(k * y), sh = std::sinh(k * y);
    Eigen::Matrix4d m;
    // d^r cosh(ky) = k^r (cosh or sinh); d^r (y g) = y g^(r) + r g^(r-1).
    for (int r = 0; r < 4; ++r) {
      const double kr = std::pow(k, r), kr1 = r > 0 ? r * std::pow(k, r - 1) : 0.0;
      const double c_r = r % 2 == 0 ? ch : sh, s_r = r % 2 == 0 ? sh : ch;
      const double c_r1 = r % 2 == 0 ? sh : ch, s_r1 = r % 2 == 0 ? ch : sh;  // order r - 1
      m(r, 0) = kr * c_r;
      m(r, 1) = y * kr * c_r + kr1 * c_r1;
      m(r, 2) = kr * s_r;
      m(r, 3) = y * kr * s_r + kr1 * s_r1;
    }
    return m;
  }
  explicit LidModes(double upper_viscosity) : mu2(upper_viscosity) { solve(); }
  // The coefficients c for y0, mu1, mu2, U.
  void solve() {
    Eigen::Matrix<double, 8, 8> a = Eigen::Matrix<double, 8, 8>::Zero();
    Eigen::Matrix<double, 8, 1> b = Eigen::Matrix<double, 8, 1>::Zero();
    const Eigen::Matrix4d at0 = basis(0.0), at1 = basis(1.0), mid = basis(y0);
    a.block<1, 4>(0, 0) = at0.row(0);
    a.block<1, 4>(1, 0) = at0.row(1);
    a.block<1, 4>(2, 4) = at1.row(0);
    a.block<1, 4>(3, 4) = at1.row(1);
    b(3) = U;
    a.block<1, 4>(4, 0) = mid.row(0);
    a.block<1, 4>(4, 4) = -mid.row(0);
    a.block<1, 4>(5, 0) = mid.row(1);
    a.block<1, 4>(5, 4) = -mid.row(1);
    const Eigen::Matrix<double, 1, 4> shear = mid.row(2) + k * k * mid.row(0);
    const Eigen::Matrix<double, 1, 4> normal = 3.0 * k * k * mid.row(1) - mid.row(3);
    a.block<1, 4>(6, 0) = mu1 * shear;
    a.block<1, 4>(6, 4) = -mu2 * shear;
    a.block<1, 4>(7, 0) = mu1 * normal;
    a.block<1, 4>(7, 4) = -mu2 * normal;
    c = a.fullPivLu().solve(b);
  }
  // f and f' at y.
  std::array<double, 2> f(double y) const {
    const Eigen::Matrix4d m = basis(y);
    const auto coef = y < y0 ? c.head<4>() : c.tail<4>();
    return {m.row(0).dot(coef), m.row(1).dot(coef)};
  }
  double u(const Point<2>& x) const { return f(x[1])[1] * std::cos(k * x[0]); }
  double v(const Point<2>& x) const { return k * f(x[1])[0] * std::sin(k * x[0]); }
};

struct LayerErrors {
  double l1 = 0.0;     // mean over the channel of the larger component error
  double uncut = 0.0;  // max over the cells the interface does not cut
};

// The steady flow at `level` with viscosities mu1 below y0 and mu2 above, the cut row's cells
// taking the harmonic mean of the sharp profile over the cell (an inner fluid's inside takes
// the harmonic mean of its smoothed one). Stokes, stepped from rest until the velocity stops
// changing (the transpose stress is explicit). dt = 1e-4: the projection is approximate (cell
// velocities are not exactly solenoidal), so the steady state depends on dt; its share falls
// with dt (at level 6 with the jump, L1 1.76e-3, 1.44e-3 and 1.48e-3 at dt = 1e-3, 3e-4 and
// 1e-4).
LayerErrors lid_errors(int level, double mu2) {
  const LidModes m(mu2);
  Tree<2> t({.roots = {1, 1}, .periodic = {true, false}, .max_level = level});
  t.refine_to([level](const tree::Box<2>&) { return level; });
  auto sides = all<2>(SideKind::periodic);
  sides[2] = {.kind = SideKind::wall};
  sides[3] = {.kind = SideKind::prescribed, .prescribed = [m](const Point<2>& x, int c, double) {
                return c == 0 ? m.U * std::cos(m.k * x[0]) : 0.0;
              }};
  FlowOptions<2> o{.stokes = true, .dt = 1e-4, .boundaries = sides};
  o.projection.tolerance = o.viscous.tolerance = 1e-11;
  NavierStokes<2> ns(t, o);
  ns.set_properties([&m](const Tree<2>& tr, std::span<double> rho, std::span<double> mu) {
    for (const auto c : tr.leaves()) {
      const double h = tr.cell_size(tr.level_of(c)), y = tr.center(c)[1];
      const double below = std::clamp((m.y0 - (y - 0.5 * h)) / h, 0.0, 1.0);
      rho[c] = 1.0;
      mu[c] = 1.0 / (below / m.mu1 + (1.0 - below) / m.mu2);
    }
  });
  std::vector<double> before(static_cast<std::size_t>(t.num_cells()));
  double change = 1.0;
  for (int s = 0; s < 20000 && change > 1e-12; ++s) {
    for (const auto c : t.leaves()) before[static_cast<std::size_t>(c)] = ns.u(0)[c];
    EXPECT_TRUE(ns.step().converged);
    change = 0.0;
    for (const auto c : t.leaves())
      change = std::max(change, std::abs(ns.u(0)[c] - before[static_cast<std::size_t>(c)]));
  }
  EXPECT_LE(change, 1e-12) << "level " << level << ": not steady";
  LayerErrors e;
  for (const auto c : t.leaves()) {
    const Point<2> x = t.center(c);
    const double h = t.cell_size(t.level_of(c));
    const double err = std::max(std::abs(ns.u(0)[c] - m.u(x)), std::abs(ns.u(1)[c] - m.v(x)));
    e.l1 += err * h * h;
    if (std::abs(x[1] - m.y0) >= 0.5 * h) e.uncut = std::max(e.uncut, err);
  }
  return e;
}

// The flat interface at y0 = 0.4 cuts a row of cells; the lid's mode shears the interface and
// stretches it (u varies along x, so the normal stress 2 mu dv/dy jumps with mu and the
// pressure jumps with it). One viscosity: second order (L1 orders 1.91, 1.98, 1.98 measured).
// mu 1:4: the error then falls at first order (L1 orders 1.75, 1.31, 0.88 measured at levels
// 3-6; 1.1 from level 4 to 6), likely from the pressure's and the normal stress's jumps,
// which the cell-centred pressure smears over the cut row. Rules that give the normal and
// tangential stresses the volume mean (the anisotropic law of Magnaudet et al. 2025,
// arXiv:2504.08648, per velocity component) measured no better here (L1 1.69e-3 at level 6
// against 1.48e-3) nor on a capsule's relaxation (docs/numerics.md, "Inner fluids").
// Asserted: second order without the jump; with it, first order at least over levels 4-6
// and the finest error within 5x of the jump-free one.
TEST(InterfaceViscosity, TwoLayerLidDrivenModeFirstOrderWhereTheInterfaceStretches) {
  std::vector<double> uniform, jump;
  for (int level = 3; level <= 6; ++level) {
    const LayerErrors u = lid_errors(level, 1.0), j = lid_errors(level, 4.0);
    uniform.push_back(u.l1);
    jump.push_back(j.l1);
    std::printf(
        "two-layer lid mode, y0 = 0.4, level %d: mu 1:1 L1 %.3e, uncut max %.3e; mu 1:4 L1 %.3e, uncut max "
        "%.3e\n",
        level, u.l1, u.uncut, j.l1, j.uncut);
  }
  testing::expect_orders_at_least("one viscosity, L1", uniform, 1.85);
  EXPECT_GT(std::log2(jump[1] / jump[3]) / 2.0, 1.0);
  EXPECT_LT(jump[3], 5.0 * uniform[3]);
}

}  // namespace
}  // namespace capsflow::fluid
