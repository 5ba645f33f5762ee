// Embedded walls on N ranks: every cell a rank owns or holds as a ghost has the fractions and
// the wall of the same cell in the serial tree, to the last bit, and the totals over the
// owned leaves are the serial totals.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include <Eigen/Geometry>

#include "fluid/embedded_geometry.hpp"
#include "fluid/embedded_surface.hpp"
#include "fluid/multigrid/elliptic_operator.hpp"
#include "fluid/multigrid/embedded_coefficients.hpp"
#include "fluid/multigrid/multigrid.hpp"
#include "fluid/multigrid/wall_flux.hpp"
#include "parallel/reduce.hpp"
#include "forest_fixtures.hpp"
#include "parallel/exact_sum.hpp"
#include "tree/distributed_forest.hpp"

namespace capsflow::tree {
namespace {

template <int D>
void check_against_serial(const TreeOptions<D>& o, const geometry::SolidPtr& solid) {
  const parallel::Comm comm = parallel::Comm::world();
  const Tree<D> serial = testing::uneven_tree(o);
  Tree<D> t = testing::uneven_tree(o);
  const auto forest = distribute(comm, t);
  const fluid::EmbeddedGeometry<D> gs(serial, solid), g(t, solid);
  std::int64_t compared = 0, differ = 0;
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
      if (!t.holds(c)) continue;
      const Index s = serial.find(l, t.coords(c));
      ASSERT_NE(s, kNone);
      if (serial.level(l).is_leaf(s) != lv.is_leaf(c)) continue;  // a ghost the local tree does not refine
      ++compared;
      bool same = g.volume()[static_cast<std::size_t>(c)] == gs.volume()[static_cast<std::size_t>(s)] &&
                  g.wall_area(c) == gs.wall_area(s);
      for (int d = 0; d < D; ++d) {
        same = same && g.faces()[d][static_cast<std::size_t>(c)] == gs.faces()[d][static_cast<std::size_t>(s)] &&
               g.wall_centroid(c)[d] == gs.wall_centroid(s)[d];
        // An owned cell's upper face too (its operator reads it): on the brick's upper sides
        // its slot is a boundary cell, which no exchange reaches.
        if (!t.owns(c)) continue;
        const auto up = static_cast<std::size_t>(lv.face_row(c)[2 * d + 1]);
        const auto up_serial = static_cast<std::size_t>(serial.level(l).face_row(s)[2 * d + 1]);
        same = same && g.faces()[d][up] == gs.faces()[d][up_serial];
      }
      if (!same) ++differ;
    }
  }
  EXPECT_GT(compared, 0);
  EXPECT_EQ(differ, 0) << "of " << compared << " cells on rank " << comm.rank();
  parallel::ExactSum fluid, fluid_serial;
  for (const Index c : t.owned_leaves())
    fluid.add(g.volume()[static_cast<std::size_t>(c)] * std::pow(t.cell_size(t.level_of(c)), D));
  for (const Index c : serial.leaves())
    fluid_serial.add(gs.volume()[static_cast<std::size_t>(c)] * std::pow(serial.cell_size(serial.level_of(c)), D));
  EXPECT_EQ(t.global_sum(fluid), fluid_serial.value());
  if constexpr (D == 3) {  // the walls' surface for ParaView: each rank its owned leaves' part
    auto count_and_area = [](const std::vector<double>& tri) {
      parallel::ExactSum area;
      for (std::size_t k = 0; k + 9 <= tri.size(); k += 9) {
        const Eigen::Vector3d a(tri[k], tri[k + 1], tri[k + 2]), b(tri[k + 3], tri[k + 4], tri[k + 5]),
            c(tri[k + 6], tri[k + 7], tri[k + 8]);
        area.add(0.5 * (b - a).cross(c - a).norm());
      }
      return std::pair{static_cast<std::int64_t>(tri.size() / 9), area};
    };
    auto [count, area] = count_and_area(fluid::wall_surface(g));
    const auto [count_serial, area_serial] = count_and_area(fluid::wall_surface(gs));
    EXPECT_EQ(parallel::global_sum(comm, count), count_serial);
    EXPECT_EQ(t.global_sum(area), area_serial.value());
  }
}

TEST(DistributedEmbeddedGeometry, MatchesSerial3D) {
  check_against_serial<3>({.roots = {1, 1, 2}, .max_level = 5}, geometry::sphere({0.5, 0.45, 0.9}, 0.37));
}

// A tube through the brick's ends: its wall cuts the faces on the upper x side.
TEST(DistributedEmbeddedGeometry, ATubeThroughTheBricksSidesMatchesSerial3D) {
  check_against_serial<3>({.roots = {2, 1, 1}, .max_level = 5},
                          geometry::complement(geometry::cylinder({.centre = {0.0, 0.47, 0.52}, .radius = 0.41})));
}

TEST(DistributedEmbeddedGeometry, MatchesSerialPeriodic2D) {
  TreeOptions<2> o{.roots = {2, 1}, .max_level = 7};
  o.periodic[0] = true;
  check_against_serial<2>(o, geometry::unite({geometry::sphere({0.1, 0.5, 0.0}, 0.3), geometry::sphere({2.1, 0.5, 0.0}, 0.3)}));
}

// Poiseuille flow in a pipe off the grid (the elliptic operator with fractions and wall
// fluxes): the same residual history and values on N ranks as on one.
template <int D>
fluid::MultigridStats solve_pipe(const Tree<D>& t, const geometry::SolidPtr& wall, std::vector<double>& u) {
  using namespace fluid;
  const EmbeddedGeometry<D> g(t, wall);
  const WallFlux<D> walls(t, g);
  std::vector<double> alpha, lambda;
  embedded_face_coefficients<D>(t, g, 1.0, alpha);
  embedded_cell_coefficients<D>(t, g, 0.0, lambda);
  const EllipticOperator<D, EmbeddedFaces<D>, EmbeddedCells, WallTerms<D>> op(
      t, {1.0, alpha.data(), g.uniform().data()}, {0.0, lambda.data(), g.uniform().data()}, BoundaryConditions<D>::all(BcKind::dirichlet), {&walls, 1.0});
  u.assign(static_cast<std::size_t>(t.num_cells()), 0.0);
  std::vector<double> b(u.size(), 0.0);
  for (const Index c : t.owned_leaves()) b[static_cast<std::size_t>(c)] = -g.volume()[static_cast<std::size_t>(c)];
  MultigridWorkspace ws;
  return fluid::solve(op, u, b, ws, {.tolerance = 1e-10, .max_cycles = 60});
}

template <int D>
void check_pipe(const TreeOptions<D>& o, const geometry::SolidPtr& wall) {
  const parallel::Comm comm = parallel::Comm::world();
  const Tree<D> serial = testing::uneven_tree(o);
  Tree<D> t = testing::uneven_tree(o);
  const auto forest = distribute(comm, t);
  std::vector<double> us, u;
  const fluid::MultigridStats s = solve_pipe(serial, wall, us), d = solve_pipe(t, wall, u);
  EXPECT_TRUE(s.converged);
  ASSERT_EQ(d.residuals.size(), s.residuals.size()) << "cycles";
  for (std::size_t i = 0; i < s.residuals.size(); ++i)
    EXPECT_NEAR(d.residuals[i], s.residuals[i], 1e-12 * s.residuals[i]) << "cycle " << i;
  double scale = 0.0, worst = 0.0;
  for (const Index c : serial.leaves()) scale = std::max(scale, std::abs(us[static_cast<std::size_t>(c)]));
  for (const Index c : t.owned_leaves()) {
    const Index sc = serial.find(t.level_of(c), t.coords(c));
    worst = std::max(worst, std::abs(u[static_cast<std::size_t>(c)] - us[static_cast<std::size_t>(sc)]));
  }
  EXPECT_LE(parallel::global_max(comm, worst), 1e-12 * scale);
}

TEST(DistributedEmbeddedWalls, PipePoissonMatchesSerial2D) {
  check_pipe<2>({.roots = {2, 1}, .max_level = 7},
                geometry::complement(geometry::cylinder({.centre = {0.0, 0.48, 0.0}, .radius = 0.37})));
}

TEST(DistributedEmbeddedWalls, PipePoissonMatchesSerial3D) {
  check_pipe<3>({.roots = {1, 1, 2}, .max_level = 5},
                geometry::complement(geometry::cylinder({.centre = {0.51, 0.47, 0.0}, .axis = {0.0, 0.0, 1.0}, .radius = 0.41})));
}

}  // namespace
}  // namespace capsflow::tree
