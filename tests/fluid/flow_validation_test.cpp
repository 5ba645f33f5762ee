// The flow solver against published and exact steady flows: the lid-driven cavity
// (Ghia, Ghia & Shin 1982), uniform and adaptive; the 3D square duct (exact series).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "cavity.hpp"
#include "fluid/duct_profile.hpp"

namespace capsflow::fluid {
namespace {

using testing::run_cavity;

// Ghia's own table deviates from accurate solutions by up to ~0.009 (v_min at Re = 100:
// Ghia -0.2453, spectral results -0.2538), so deviations from it are bounded below by that.
TEST(Cavity, Re100AdaptiveMatchesGhiaWithFewerCells) {
  tree::Tree<2> t({.roots = {1, 1}, .max_level = 7});
  t.refine_to([](const tree::Box<2>&) { return 5; });
  const auto r = run_cavity(t, 100, 15.0, 1e-4, 0.002);
  std::printf("adaptive cavity Re 100: %d leaves, u %.4f v %.4f\n", r.leaves, r.u_error, r.v_error);
  EXPECT_LE(r.u_error, 0.01);
  EXPECT_LE(r.v_error, 0.012);
  EXPECT_LT(r.leaves, 128 * 128 / 4) << "the adaptive tree must use far fewer cells than 128^2";
}

TEST(Cavity, Re100UniformAndAdaptiveAgree) {
  tree::Tree<2> uniform({.roots = {1, 1}, .max_level = 6});
  uniform.refine_to([](const tree::Box<2>&) { return 6; });
  const auto ru = run_cavity(uniform, 100, 15.0, 1e-4);
  tree::Tree<2> adaptive({.roots = {1, 1}, .max_level = 6});
  adaptive.refine_to([](const tree::Box<2>&) { return 4; });
  const auto ra = run_cavity(adaptive, 100, 15.0, 1e-4, 0.002);
  std::printf("cavity 64^2: uniform u %.4f v %.4f (%d leaves), adaptive u %.4f v %.4f (%d leaves)\n", ru.u_error,
              ru.v_error, ru.leaves, ra.u_error, ra.v_error, ra.leaves);
  EXPECT_LE(ru.u_error, 0.01);
  EXPECT_LE(ru.v_error, 0.016);
  EXPECT_LE(ra.u_error, ru.u_error + 0.003);
  EXPECT_LE(ra.v_error, ru.v_error + 0.003);
  EXPECT_LT(ra.leaves, ru.leaves / 2);
}

// A relative wavelet tolerance follows a decaying flow: the same velocity field scaled
// down 100x keeps its grid with the relative tolerance, and loses most of its refinement
// with the absolute one (the adaptive seed relaxation drifted from the uniform one by more
// than 1 % in D12 once max|u| fell to a few times the absolute tolerance).
TEST(Adaptation, RelativeToleranceFollowsADecayingFlow) {
  auto leaves_after_adapt = [](double scale, double relative) {
    tree::Tree<2> t({.roots = {1, 1}, .max_level = 7});
    t.refine_to([](const tree::Box<2>&) { return 7; });
    std::array<SideFlow<2>, 4> sides{};
    NavierStokes<2> ns(t, {.Re = 1.0, .stokes = true, .boundaries = sides});
    for (const auto c : t.leaves()) {  // a vortex, zero on the walls
      const auto x = t.center(c);
      ns.u(0)[c] = scale * std::sin(M_PI * x[0]) * std::sin(M_PI * x[0]) * std::sin(2 * M_PI * x[1]);
      ns.u(1)[c] = -scale * std::sin(2 * M_PI * x[0]) * std::sin(M_PI * x[1]) * std::sin(M_PI * x[1]);
    }
    const double tolerance = ns.velocity_tolerance(1e-3, relative);
    (void)ns.adapt(1e-3, {.min_level = 3}, relative);
    return std::make_pair(t.num_leaves(), tolerance);
  };
  // The rule: min(absolute, relative max|u|), floored at 1e-3 absolute.
  const auto [fast_rel, tol_fast] = leaves_after_adapt(1.0, 1e-4);
  const auto [slow_rel, tol_slow] = leaves_after_adapt(0.01, 1e-4);
  const auto [slow_abs, tol_abs] = leaves_after_adapt(0.01, 0.0);
  const auto [rest, tol_rest] = leaves_after_adapt(0.0, 1e-4);
  std::printf("leaves: fast %d (tolerance %.1e), slow relative %d (%.1e), slow absolute %d (%.1e), rest %d (%.1e)\n",
              fast_rel, tol_fast, slow_rel, tol_slow, slow_abs, tol_abs, rest, tol_rest);
  EXPECT_NEAR(tol_fast, 1e-4, 1e-7);  // 1e-4 x max|u| (0.9995 at the cell centres) < 1e-3
  EXPECT_DOUBLE_EQ(tol_slow, 1e-6);   // 1e-4 x 0.01 < 1e-6, the floor
  EXPECT_DOUBLE_EQ(tol_abs, 1e-3);
  EXPECT_DOUBLE_EQ(tol_rest, 1e-6);   // at rest: the floor, not zero
  EXPECT_EQ(slow_rel, fast_rel);      // the same field, scaled: the same grid
  EXPECT_LT(slow_abs, slow_rel / 2);
  // Round-off refines nothing: at rest every cell coarsens (one level per adapt: 128^2 ->
  // 64^2), as the decayed flow does with the absolute tolerance.
  EXPECT_EQ(rest, 64 * 64);
  EXPECT_EQ(slow_abs, 64 * 64);
}

// Developed flow in a square duct (periodic along x, walls around, driven by a uniform
// force G = -dp/dx): the centreline and the flow rate match the exact series.
TEST(SquareDuct, DevelopedFlowMatchesExactSeries) {
  for (const bool adapt : {false, true}) {
    tree::Tree<3> t({.roots = {1, 1, 1}, .root_size = 2.0, .origin = {0, -1, -1}, .periodic = {true, false, false},
                     .max_level = 5});
    // Uniform 32^2 cross-section, or 16^2 in the core with the walls refined to 32.
    t.refine_to([adapt](const tree::Box<3>& b) {
      if (!adapt) return 5;
      const double wall = std::min({1 - std::abs(b.lo[1]), 1 - std::abs(b.hi[1]), 1 - std::abs(b.lo[2]), 1 - std::abs(b.hi[2])});
      return wall < 0.2 ? 5 : 4;
    });
    std::array<SideFlow<3>, 6> sides{};
    sides[0].kind = sides[1].kind = SideKind::periodic;
    FlowOptions<3> o{.Re = 1.0, .stokes = false, .dt = 0.05, .boundaries = sides};
    o.projection.tolerance = o.viscous.tolerance = 1e-6;
    NavierStokes<3> ns(t, o);
    const double G = 1.0;
    ns.set_face_force([&](const tree::Tree<3>& tr, FaceField<3>& f) {
      for_each_face<3>(tr, [&](int d, Index, Index hi, double, const tree::Level<3>&) { f[d][hi] = d == 0 ? G : 0.0; });
      restrict_faces<3>(tr, f);
    });
    for (int s = 0; s < 80; ++s) (void)ns.step();  // t = 4: four viscous times a^2/nu
    // Flow rate through the cross-section and the centreline velocity.
    double q = 0.0, centre = 0.0, worst = 0.0, umax_exact = duct_velocity(0, 0, 1, 1);
    for (const auto c : t.leaves()) {
      const auto x = t.center(c);
      const double h = t.cell_size(t.level_of(c));
      q += ns.u(0)[c] * h * h * h / 2.0;  // mean over the length 2
      worst = std::max(worst, std::abs(ns.u(0)[c] - G * duct_velocity(x[1], x[2], 1, 1)));
      if (std::abs(x[1]) < h && std::abs(x[2]) < h) centre = std::max(centre, ns.u(0)[c]);
    }
    const double q_exact = G * duct_flow_rate(1, 1);
    std::printf("square duct (%s): Q %.6f exact %.6f, centre %.5f exact %.5f, max error %.2e\n",
                adapt ? "wall-refined" : "uniform", q, q_exact, centre, umax_exact, worst);
    EXPECT_NEAR(q / q_exact, 1.0, 0.01);
    EXPECT_LT(worst, 0.01 * umax_exact);
  }
}

// The exact series itself against the reference table (White's solution, 30 digits).
TEST(SquareDuct, SeriesMatchesReferenceTable) {
  EXPECT_NEAR(duct_flow_rate(1, 1), 0.562308059820615, 1e-12);
  EXPECT_NEAR(duct_mean_velocity(1, 1), 0.140577014955154, 1e-12);
  EXPECT_NEAR(duct_velocity(0, 0, 1, 1), 0.294685413126055, 1e-9);
  EXPECT_NEAR(duct_flow_rate(1, 2) / 2, 0.914726708478, 1e-9);  // Q / (a^3 b) for b/a = 2
  EXPECT_NEAR(duct_velocity(1.0, 0.3, 1, 1), 0.0, 1e-15);  // no-slip wall
}

// The memo gives the series' values bit for bit, first call and repeated, from threads at once.
TEST(SquareDuct, MemoizedProfileIsTheSeries) {
  const DuctProfileMemo profile(0.5, 1.0);
  std::vector<std::pair<double, double>> points;
  for (int i = -8; i <= 8; ++i)
    for (int j = -16; j <= 16; ++j) points.emplace_back((i + 0.5) / 16.0, j / 16.0);
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<double> got(points.size());
#pragma omp parallel for
    for (std::size_t k = 0; k < points.size(); ++k) got[k] = profile(points[k].first, points[k].second);
    for (std::size_t k = 0; k < points.size(); ++k)
      ASSERT_EQ(got[k], duct_velocity(points[k].first, points[k].second, 0.5, 1.0)) << "pass " << pass << " point " << k;
  }
  const DuctProfileMemo copy = profile;  // shares the memo
  EXPECT_EQ(copy(0.03125, 0.0), duct_velocity(0.03125, 0.0, 0.5, 1.0));
}

}  // namespace
}  // namespace capsflow::fluid
