// The walls' flux (fluid/multigrid/wall_flux.hpp) and the cells without fluid in the embedded
// operator (EmbeddedFaces, kStencilEmpty): every cut cell's flux is exact for linear fields,
// on the fit's stencils and on the column of a wall along a grid axis; a channel's planar
// walls take the column; the empty cells' short path and the solid side's injected halos
// give the array path's and the prolonged halos' numbers to the bit, the closed-face cells'
// constant stencil the array path's to rounding.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include "embedded_trees.hpp"
#include "fluid/embedded_geometry.hpp"
#include "fluid/multigrid/elliptic_operator.hpp"
#include "fluid/multigrid/embedded_coefficients.hpp"
#include "fluid/multigrid/multigrid.hpp"
#include "fluid/multigrid/wall_flux.hpp"
#include "geometry/solid.hpp"

namespace capsflow::fluid {
namespace {

using tree::Index;
using tree::Tree;

struct Count {
  std::int64_t cut = 0;      // on the finest level, where the errors are taken
  std::int64_t cut_all = 0;  // on every level
  std::int64_t columns = 0;  // of those, fitted on their column (every level)
  double worst = 0.0;        // max |flux - exact| / (|N| / h^D)
};

// a = 1 + g . x on every active cell; the flux through each cut cell's wall against
// g . N / h^D, with a_wall the field at the wall's centroid.
Count linear_flux_errors(const Tree<3>& t, const geometry::SolidPtr& solid) {
  const EmbeddedGeometry<3> g(t, solid);
  const WallFlux<3> walls(t, g);
  const double grad[3] = {0.3, -1.7, 0.9};
  auto field = [&](const tree::Point<3>& x) { return 1.0 + grad[0] * x[0] + grad[1] * x[1] + grad[2] * x[2]; };
  std::vector<double> a(static_cast<std::size_t>(t.num_cells()), 0.0);
  for (int l = 0; l <= t.depth(); ++l)
    for (Index c = t.level(l).active_begin(); c < t.level(l).active_end(); ++c) a[static_cast<std::size_t>(c)] = field(t.center(c));
  Count n;
  // The finest level: a coarse cell around much of a sphere may have too few cells with
  // fluid for a fit (WallFlux::fallbacks, a one-sided difference).
  for (int l = t.depth(); l <= t.depth(); ++l) {
    const double volume = std::pow(t.cell_size(l), 3);
    for (const Index c : walls.cut_cells(l)) {
      const std::array<double, 3> area = g.wall_normal_area(c);
      const double exact = (grad[0] * area[0] + grad[1] * area[1] + grad[2] * area[2]) / volume;
      const double scale = std::sqrt(area[0] * area[0] + area[1] * area[1] + area[2] * area[2]) / volume;
      const double flux = walls.flux(c, a, field(g.wall_centroid(c)));
      n.worst = std::max(n.worst, std::abs(flux - exact) / scale);
      ++n.cut;
    }
  }
  for (int l = 0; l <= t.depth(); ++l) n.cut_all += static_cast<std::int64_t>(walls.cut_cells(l).size());
  n.columns = walls.columns();
  return n;
}

TEST(WallFlux, EveryCutCellsFluxIsExactForLinearFields) {
  Tree<3> t({.roots = {1, 1, 1}, .max_level = 4});
  t.refine_to([](const tree::Box<3>&) { return 4; });
  // Walls on cell faces (levels >= 2), walls off the grid, and a sphere.
  const Count on_faces = linear_flux_errors(t, geometry::complement(geometry::box({-1.0, 0.25, -1.0}, {2.0, 0.75, 2.0})));
  const Count off_grid = linear_flux_errors(t, geometry::complement(geometry::box({-1.0, 0.2345, -1.0}, {2.0, 0.8123, 2.0})));
  const Count sphere = linear_flux_errors(t, geometry::sphere({0.52, 0.47, 0.55}, 0.31));
  std::printf("cut cells (columns): walls on faces %lld (%lld), off the grid %lld (%lld), sphere %lld (%lld); "
              "worst relative errors on the finest level %.1e %.1e %.1e\n",
              static_cast<long long>(on_faces.cut_all), static_cast<long long>(on_faces.columns),
              static_cast<long long>(off_grid.cut_all), static_cast<long long>(off_grid.columns),
              static_cast<long long>(sphere.cut_all), static_cast<long long>(sphere.columns), on_faces.worst, off_grid.worst,
              sphere.worst);
  EXPECT_LT(on_faces.worst, 1e-12);
  EXPECT_LT(off_grid.worst, 1e-12);
  EXPECT_LT(sphere.worst, 1e-12);
  // Planar walls along the grid: every cut cell with a neighbour into the fluid on its line
  // takes the column (walls on faces: all of them; off the grid: those whose centre is in the
  // fluid); a sphere's cells the fit.
  EXPECT_EQ(on_faces.columns, on_faces.cut_all);
  EXPECT_GT(off_grid.columns, 0);
  EXPECT_LT(off_grid.columns, off_grid.cut_all);
  EXPECT_LT(sphere.columns, sphere.cut_all / 10);
}

// The seed channel's kind of walls (a box inside a larger brick) on a tree refined along
// them: the operator with the empty cells' short path and with those cells sent down the
// array path give the same residuals and relaxed values, to the bit.
TEST(EmbeddedOperator, CellsWithoutFluidCostTheirCellTermAndChangeNoNumber) {
  const auto solid = geometry::complement(geometry::box({-1.0, 0.2345, 0.25}, {2.0, 0.8123, 0.75}));
  const Tree<3> t = testing::refined_along<3>(solid, 2, 5, 2.0);
  const EmbeddedGeometry<3> g(t, solid);
  const WallFlux<3> walls(t, g, WallFlux<3>::Band::none);
  std::vector<double> alpha, lambda;
  embedded_face_coefficients<3>(t, g, 0.7, alpha);
  embedded_cell_coefficients<3>(t, g, -50.0, lambda);
  std::vector<std::uint8_t> arrays(g.uniform().begin(), g.uniform().end());
  std::int64_t empty = 0;
  for (auto& flag : arrays)
    if (flag == kStencilEmpty) {
      flag = kStencilArrays;
      ++empty;
    }
  ASSERT_GT(empty, 0);
  // Some of them next to a finer region: the operator's flux-matching path.
  std::int64_t empty_next_to_finer = 0;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<3>& lv = t.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
      if (lv.leaf[c - lv.base] == tree::Level<3>::kLeafNextToFiner && g.uniform()[c] == kStencilEmpty) ++empty_next_to_finer;
  }
  ASSERT_GT(empty_next_to_finer, 0);
  using Op = EllipticOperator<3, EmbeddedFaces<3>, EmbeddedCells, WallTerms<3>>;
  const auto bc = tree::BoundaryConditions<3>::all(tree::BcKind::dirichlet);
  const Op fast(t, {0.7, alpha.data(), g.uniform().data()}, {-50.0, lambda.data(), g.uniform().data()}, bc, {&walls, 0.7});
  const Op slow(t, {0.7, alpha.data(), arrays.data()}, {-50.0, lambda.data(), arrays.data()}, bc, {&walls, 0.7});
  // A field that is not zero in the solid either: the short path must not assume it is.
  std::vector<double> u(static_cast<std::size_t>(t.num_cells()), 0.0), b(u.size(), 0.0);
  for (const Index c : t.leaves()) {
    const tree::Point<3> x = t.center(c);
    u[static_cast<std::size_t>(c)] = std::sin(3.0 * x[0]) + x[1] * x[2];
    b[static_cast<std::size_t>(c)] = std::cos(2.0 * x[1]);
  }
  t.sync(std::span<double>(u), bc);
  std::vector<double> r_fast(u.size(), 0.0), r_slow(u.size(), 0.0);
  const double worst_fast = fast.residual(u, b, r_fast), worst_slow = slow.residual(u, b, r_slow);
  EXPECT_EQ(worst_fast, worst_slow);
  EXPECT_EQ(r_fast, r_slow);
  // Relaxation of the finest level from the residual.
  const MultigridOptions opt{.wall_band_passes = 0};
  std::vector<double> d_fast(u.size(), 0.0), d_slow(u.size(), 0.0), scratch(u.size(), 0.0);
  fast.relax(t.depth(), d_fast, r_fast, 2, opt, scratch);
  slow.relax(t.depth(), d_slow, r_slow, 2, opt, scratch);
  EXPECT_EQ(d_fast, d_slow);
  // And a whole solve.
  std::vector<double> s_fast(u.size(), 0.0), s_slow(u.size(), 0.0);
  MultigridWorkspace w_fast, w_slow;
  const MultigridStats a = solve(fast, s_fast, b, w_fast, {.tolerance = 1e-9, .wall_band_passes = 0});
  const MultigridStats c = solve(slow, s_slow, b, w_slow, {.tolerance = 1e-9, .wall_band_passes = 0});
  EXPECT_TRUE(a.converged);
  EXPECT_EQ(a.cycles, c.cycles);
  EXPECT_EQ(s_fast, s_slow);
}

// The layer along walls that lie on grid faces (kStencilClosedFace: a full cell with one
// closed face) takes the constant stencil without that face: the same residuals and relaxed
// values as on the array path, to rounding, and solves that agree to their tolerance, for
// the viscous kind of operator (with the walls' flux) and the projection's (pinned).
TEST(EmbeddedOperator, CellsWithAClosedFaceTakeTheConstantStencil) {
  // z walls on level-5 faces that are not level 4's (the layer's neighbour into the fluid
  // lies in the next level-4 cell), y walls across cells.
  const auto solid = geometry::complement(geometry::box({-1.0, 0.2345, 0.28125}, {2.0, 0.8123, 0.71875}));
  std::int64_t face_columns = 0, others = 0;
  // Refined two cells deep along the walls, and only at them (next to coarser cells): the
  // layer's cells take the face column either way, the brick's wall gradient from the cell
  // alone, whatever its neighbour's level.
  for (const double band : {2.0, 0.0}) {
    SCOPED_TRACE(band);
    const Tree<3> t = testing::refined_along<3>(solid, 2, 5, band);
    const EmbeddedGeometry<3> g(t, solid);
    const WallFlux<3> walls(t, g, WallFlux<3>::Band::none);
    std::vector<double> alpha, lambda, pins;
    embedded_face_coefficients<3>(t, g, 0.7, alpha);
    embedded_cell_coefficients<3>(t, g, -50.0, lambda);
    embedded_cell_coefficients<3>(t, g, 0.0, pins);
    std::vector<std::uint8_t> arrays(g.uniform().begin(), g.uniform().end());
    std::array<std::int64_t, 6> closed{};
    for (std::size_t c = 0; c < arrays.size(); ++c) {
      EXPECT_TRUE(!walls.face_column(static_cast<Index>(c)) || closed_face_stencil(arrays[c])) << "cell " << c;
      if (closed_face_stencil(arrays[c])) {
        ++closed[static_cast<std::size_t>(arrays[c] - kStencilClosedFace)];
        (walls.face_column(static_cast<Index>(c)) ? face_columns : others) += 1;
        arrays[c] = kStencilArrays;
      }
    }
    for (int k = 4; k < 6; ++k) EXPECT_GT(closed[static_cast<std::size_t>(k)], 0) << "face " << k;
    EXPECT_EQ(closed[2] + closed[3], 0);  // the y walls cut their cells
    // A field that is not zero in the solid either.
    std::vector<double> u(static_cast<std::size_t>(t.num_cells()), 0.0), b(u.size(), 0.0);
    for (const Index c : t.leaves()) {
      const tree::Point<3> x = t.center(c);
      u[static_cast<std::size_t>(c)] = std::sin(3.0 * x[0]) + x[1] * x[2];
      b[static_cast<std::size_t>(c)] = std::cos(2.0 * x[1]) * g.volume()[static_cast<std::size_t>(c)];
    }
    auto max_abs = [](const std::vector<double>& v) {
      double m = 0.0;
      for (const double x : v) m = std::max(m, std::abs(x));
      return m;
    };
    auto max_diff = [](const std::vector<double>& v, const std::vector<double>& w) {
      double m = 0.0;
      for (std::size_t i = 0; i < v.size(); ++i) m = std::max(m, std::abs(v[i] - w[i]));
      return m;
    };
    auto compare = [&](const auto& fast, const auto& slow, const tree::BoundaryConditions<3>& bc, const char* what) {
      SCOPED_TRACE(what);
      std::vector<double> a = u;
      t.sync(std::span<double>(a), bc);
      std::vector<double> r_fast(u.size(), 0.0), r_slow(u.size(), 0.0);
      (void)fast.residual(a, b, r_fast);
      (void)slow.residual(a, b, r_slow);
      EXPECT_LE(max_diff(r_fast, r_slow), 1e-13 * max_abs(r_slow));
      const MultigridOptions opt{.wall_band_passes = 0};
      std::vector<double> d_fast(u.size(), 0.0), d_slow(u.size(), 0.0), scratch(u.size(), 0.0);
      fast.relax(t.depth(), d_fast, r_slow, 2, opt, scratch);
      slow.relax(t.depth(), d_slow, r_slow, 2, opt, scratch);
      EXPECT_LE(max_diff(d_fast, d_slow), 1e-12 * max_abs(d_slow));
      std::vector<double> s_fast(u.size(), 0.0), s_slow(u.size(), 0.0);
      MultigridWorkspace w_fast, w_slow;
      const MultigridStats sf = solve(fast, s_fast, b, w_fast, {.tolerance = 1e-10, .wall_band_passes = 0});
      const MultigridStats ss = solve(slow, s_slow, b, w_slow, {.tolerance = 1e-10, .wall_band_passes = 0});
      EXPECT_TRUE(sf.converged && ss.converged);
      EXPECT_EQ(sf.cycles, ss.cycles);
      EXPECT_LE(max_diff(s_fast, s_slow), 1e-8 * max_abs(s_slow));
    };
    using Viscous = EllipticOperator<3, EmbeddedFaces<3>, EmbeddedCells, WallTerms<3>>;
    const auto dirichlet = tree::BoundaryConditions<3>::all(tree::BcKind::dirichlet);
    compare(Viscous(t, {0.7, alpha.data(), g.uniform().data()}, {-50.0, lambda.data(), g.uniform().data()}, dirichlet,
                    {&walls, 0.7}),
            Viscous(t, {0.7, alpha.data(), arrays.data()}, {-50.0, lambda.data(), arrays.data()}, dirichlet, {&walls, 0.7}),
            dirichlet, "viscous");
    using Pressure = EllipticOperator<3, EmbeddedFaces<3>, PinnedCells>;
    auto neumann = tree::BoundaryConditions<3>::all(tree::BcKind::neumann);
    neumann.side[1].kind = tree::BcKind::dirichlet;  // x_hi: a defined solution
    compare(Pressure(t, {0.7, alpha.data(), g.uniform().data()}, {pins.data()}, neumann),
            Pressure(t, {0.7, alpha.data(), arrays.data()}, {pins.data()}, neumann), neumann, "pressure");
  }
  EXPECT_GT(face_columns, 0);
  EXPECT_EQ(others, 0);
}

// The halos of the cells without fluid injected in the solves' syncs (Tree::injected_halos):
// the same residuals, cycles and solutions, to the bit, for the viscous kind of operator
// and the projection's (pinned, singular), by cycles and by the Krylov iteration; after a
// solve every cell holds what it held without injection.
TEST(EmbeddedOperator, InjectedSolidHalosChangeNoNumber) {
  // Walls refined to level 4 on their fluid side, the solid kept coarse (level 3 next to
  // them), and a level-5 patch against the wall on a face of the level-4 cells: the
  // prolongations to it read level-4 halos of solid cells, which keep their prolonged values.
  const auto solid = geometry::complement(geometry::box({-1.0, 0.2345, 0.25}, {2.0, 0.8125, 0.75}));
  const Eigen::Vector3d patch(0.5, 0.75, 0.5);
  const Tree<3> t = testing::refined_by<3>(5, [&](const Eigen::Vector3d& centre, double half) {
    const double phi = solid->signed_distance(centre);
    if (phi <= 0.0) return 2;
    if ((centre - patch).norm() <= 0.08 + half) return 5;
    return phi <= half + 0.125 ? 4 : 2;
  });
  const EmbeddedGeometry<3> g(t, solid);
  const WallFlux<3> walls(t, g, WallFlux<3>::Band::none);
  std::vector<std::uint8_t> closed(g.uniform().size());
  for (std::size_t c = 0; c < closed.size(); ++c) closed[c] = g.uniform()[c] == kStencilEmpty;
  const tree::InjectedHalos injected = t.injected_halos(closed);
  // Some groups injected, and some of closed cells kept for a prolongation that reads them.
  std::int64_t flagged = 0, kept = 0;
  for (int l = 1; l <= t.depth(); ++l)
    for (std::size_t k = 0; k < injected[static_cast<std::size_t>(l)].size(); ++k) {
      flagged += injected[static_cast<std::size_t>(l)][k];
      kept += !injected[static_cast<std::size_t>(l)][k] && closed[static_cast<std::size_t>(t.level(l).halo_parent[k])];
    }
  ASSERT_GT(flagged, 0);
  ASSERT_GT(kept, 0);
  std::vector<double> alpha, lambda, pins;
  embedded_face_coefficients<3>(t, g, 0.7, alpha);
  embedded_cell_coefficients<3>(t, g, -50.0, lambda);
  embedded_cell_coefficients<3>(t, g, 0.0, pins);
  std::vector<double> u(static_cast<std::size_t>(t.num_cells()), 0.0), b(u.size(), 0.0), b0(u.size(), 0.0);
  for (const Index c : t.leaves()) {
    const tree::Point<3> x = t.center(c);
    u[static_cast<std::size_t>(c)] = std::sin(3.0 * x[0]) + x[1] * x[2];
    b[static_cast<std::size_t>(c)] = std::cos(2.0 * x[1]);
  }
  // The projection's right-hand side: zero mean over the leaves, none without fluid.
  double mean = 0.0, volume = 0.0;
  for (const Index c : t.leaves()) {
    const double v = std::pow(t.cell_size(t.level_of(c)), 3) * g.volume()[static_cast<std::size_t>(c)];
    mean += v * b[static_cast<std::size_t>(c)];
    volume += v;
  }
  for (const Index c : t.leaves())
    b0[static_cast<std::size_t>(c)] = g.volume()[static_cast<std::size_t>(c)] > 0.0 ? b[static_cast<std::size_t>(c)] - mean / volume : 0.0;
  auto compare = [&](const auto& with, const auto& without, std::span<const double> rhs) {
    std::vector<double> u1 = u, u2 = u;
    t.sync_leaf_neighbors(u1, with.bc(), tree::Prolongation::quadratic, with.injected_halos());
    t.sync_leaf_neighbors(u2, without.bc(), tree::Prolongation::quadratic, without.injected_halos());
    EXPECT_NE(u1, u2);  // the injection took effect
    std::vector<double> r1(u.size(), 0.0), r2(u.size(), 0.0);
    EXPECT_EQ(with.residual(u1, rhs, r1), without.residual(u2, rhs, r2));
    EXPECT_EQ(r1, r2);
    t.refill_injected_halos(u1, with.bc(), tree::Prolongation::quadratic, *with.injected_halos());
    EXPECT_EQ(u1, u2);
    for (const bool krylov : {false, true}) {
      std::vector<double> s1(u.size(), 0.0), s2(u.size(), 0.0);
      MultigridWorkspace w1, w2;
      const MultigridOptions opt{.tolerance = 1e-9, .krylov = krylov, .wall_band_passes = 0};
      const MultigridStats a = solve(with, s1, rhs, w1, opt);
      const MultigridStats c = solve(without, s2, rhs, w2, opt);
      EXPECT_TRUE(a.converged) << "krylov " << krylov;
      EXPECT_EQ(a.residuals, c.residuals) << "krylov " << krylov;
      EXPECT_EQ(s1, s2) << "krylov " << krylov;
    }
  };
  const auto dirichlet = tree::BoundaryConditions<3>::all(tree::BcKind::dirichlet);
  using Viscous = EllipticOperator<3, EmbeddedFaces<3>, EmbeddedCells, WallTerms<3>>;
  compare(Viscous(t, {0.7, alpha.data(), g.uniform().data(), &injected}, {-50.0, lambda.data(), g.uniform().data()}, dirichlet,
                  {&walls, 0.7}),
          Viscous(t, {0.7, alpha.data(), g.uniform().data()}, {-50.0, lambda.data(), g.uniform().data()}, dirichlet, {&walls, 0.7}),
          b);
  const auto neumann = tree::BoundaryConditions<3>::all(tree::BcKind::neumann);
  using Pressure = EllipticOperator<3, EmbeddedFaces<3>, PinnedCells>;
  compare(Pressure(t, {1.0, alpha.data(), g.uniform().data(), &injected}, {pins.data()}, neumann),
          Pressure(t, {1.0, alpha.data(), g.uniform().data()}, {pins.data()}, neumann), b0);
}

}  // namespace
}  // namespace capsflow::fluid
