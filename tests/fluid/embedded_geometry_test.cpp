// Embedded walls on the tree: the fluid volume and wall area of a sphere and a circle
// converge at second order; every cell of every level keeps the discrete divergence theorem
// and the coarse-fine consistency the operators need; an adaptive tree refined along the wall
// gives the uniform tree's totals; the cells on both sides of a periodic seam see one wall; a
// rebuild after an adaptation, which keeps the cuts it made before, is a fresh evaluation.
#include "fluid/embedded_geometry.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "embedded_trees.hpp"
#include "geometry/cut_cell.hpp"
#include "parallel/exact_sum.hpp"

namespace capsflow::fluid {
namespace {

using tree::Index;
using tree::Tree;

const double kPi = std::acos(-1.0);

template <int D>
Tree<D> uniform_tree(int level, bool periodic_x = false) {
  tree::TreeOptions<D> o;
  o.roots.fill(1);
  o.periodic[0] = periodic_x;
  o.max_level = level;
  Tree<D> t(o);
  t.refine_to([level](const tree::Box<D>&) { return level; });
  return t;
}

geometry::SolidPtr ball(double x, double y, double z, double r) { return geometry::sphere({x, y, z}, r); }

struct Totals {
  double fluid = 0.0;  // volume
  double wall = 0.0;   // area
};

template <int D>
Totals totals(const Tree<D>& t, const EmbeddedGeometry<D>& g) {
  parallel::ExactSum fluid, wall;
  for (const Index c : t.owned_leaves()) {
    fluid.add(g.volume()[static_cast<std::size_t>(c)] * std::pow(t.cell_size(t.level_of(c)), D));
    wall.add(g.wall_area(c));
  }
  return {t.global_sum(fluid), t.global_sum(wall)};
}

TEST(EmbeddedGeometry, SphereVolumeAndAreaConvergeAtSecondOrder) {
  const double r = 0.3;
  const double exact_fluid = 1.0 - 4.0 / 3.0 * kPi * r * r * r, exact_wall = 4.0 * kPi * r * r;
  std::vector<double> volume_error, area_error;
  for (int level = 4; level <= 6; ++level) {
    const Tree<3> t = uniform_tree<3>(level);
    const EmbeddedGeometry<3> g(t, ball(0.513, 0.478, 0.502, r));
    const Totals s = totals(t, g);
    volume_error.push_back(std::abs(s.fluid - exact_fluid));
    area_error.push_back(std::abs(s.wall - exact_wall));
    std::printf("sphere, level %d: volume error %.3e, area error %.3e\n", level, volume_error.back(), area_error.back());
  }
  for (std::size_t k = 1; k < volume_error.size(); ++k) {
    EXPECT_GT(std::log2(volume_error[k - 1] / volume_error[k]), 1.8) << "volume, level " << k + 4;
    EXPECT_GT(std::log2(area_error[k - 1] / area_error[k]), 1.8) << "area, level " << k + 4;
  }
  EXPECT_LT(volume_error.back() / (exact_wall * std::pow(2.0, -6)), 0.01);
}

TEST(EmbeddedGeometry, CircleAreaAndPerimeterConvergeAtSecondOrder) {
  const double r = 0.27;
  std::vector<double> volume_error, area_error;
  for (int level = 4; level <= 7; ++level) {
    const Tree<2> t = uniform_tree<2>(level);
    // The sphere's section z = 0 is the circle; fluid outside it.
    const EmbeddedGeometry<2> g(t, ball(0.507, 0.488, 0.0, r));
    const Totals s = totals(t, g);
    volume_error.push_back(std::abs(s.fluid - (1.0 - kPi * r * r)));
    area_error.push_back(std::abs(s.wall - 2.0 * kPi * r));
    std::printf("circle, level %d: area error %.3e, perimeter error %.3e\n", level, volume_error.back(), area_error.back());
  }
  for (std::size_t k = 1; k < volume_error.size(); ++k) {
    EXPECT_GT(std::log2(volume_error[k - 1] / volume_error[k]), 1.8) << "area, level " << k + 4;
    EXPECT_GT(std::log2(area_error[k - 1] / area_error[k]), 1.7) << "perimeter, level " << k + 4;
  }
}

using testing::refined_along;

template <int D>
void check_consistency(const Tree<D>& t, const EmbeddedGeometry<D>& g, bool adaptive = true) {
  constexpr int C = tree::kChildren<D>;
  const auto& f = g.faces();
  const auto v = g.volume();
  int cut = 0, coarse_faces = 0;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double h = t.cell_size(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
      const auto s = static_cast<std::size_t>(c);
      const Index* row = lv.face_row(c);
      const Index first = lv.first_child[s - static_cast<std::size_t>(lv.base)];
      if (lv.is_leaf(c)) {
        // A leaf's volume is the cut of its own box (the face it shares with a coarse
        // neighbour aside).
        std::array<double, C> phi{};
        const tree::Box<D> b = t.box(c);
        for (int k = 0; k < C; ++k) {
          tree::Point<D> x{};
          for (int d = 0; d < D; ++d) x[d] = (k >> d & 1) ? b.hi[d] : b.lo[d];
          phi[static_cast<std::size_t>(k)] = g.signed_distance(x);
        }
        const geometry::CellCut<D> own = geometry::cut_cell<D>(phi);
        ASSERT_DOUBLE_EQ(v[s], own.volume) << "leaf " << c;
        ASSERT_NEAR(g.wall_area(c), own.wall_area * std::pow(h, D - 1), 1e-15);
        for (int d = 0; d < D; ++d) {
          const Index lo = row[2 * d];
          if (lo < lv.active_end() && !lv.is_leaf(lo)) {  // a coarse face: the mean of the fine ones
            double mean = 0.0;
            for (int b2 = 0; b2 < C; ++b2)
              if (!tree::child_bit(b2, d)) mean += f[d][static_cast<std::size_t>(first + b2)];
            ASSERT_DOUBLE_EQ(f[d][s], mean / (C / 2));
            ++coarse_faces;
          } else {
            ASSERT_DOUBLE_EQ(f[d][s], own.face[static_cast<std::size_t>(2 * d)]);
          }
          // An open face has fluid on both sides.
          if (f[d][s] > 0.0) {
            ASSERT_GT(v[s], 0.0);
            if (lo < lv.active_end() && lv.is_leaf(lo)) {
              ASSERT_GT(v[static_cast<std::size_t>(lo)], 0.0);
            }
          }
        }
      } else {
        double mean = 0.0;
        for (int b2 = 0; b2 < C; ++b2) mean += v[static_cast<std::size_t>(first + b2)];
        ASSERT_DOUBLE_EQ(v[s], mean / C) << "parent " << c;
      }
      // The divergence theorem with the faces the cell has.
      const auto n = g.wall_normal_area(c);
      double vector_length = 0.0;
      for (int d = 0; d < D; ++d) {
        vector_length += n[d] * n[d];
        ASSERT_NEAR(n[d], std::pow(h, D - 1) * (f[d][s] - f[d][static_cast<std::size_t>(row[2 * d + 1])]), 1e-15);
      }
      if (g.wall_area(c) > 0.0) ++cut;
      ASSERT_LE(std::sqrt(vector_length), g.wall_area(c) * (1 + 1e-12) + 1e-15) << "cell " << c << " level " << l;
    }
  }
  EXPECT_GT(cut, 0);
  if (adaptive) {
    EXPECT_GT(coarse_faces, 0);
  }
}

TEST(EmbeddedGeometry, EveryLevelKeepsTheDivergenceTheoremAndCoarseFineConsistency) {
  // A ball with a bite out of it: convex and concave walls, edges where the two spheres meet.
  auto bitten = [](double z) { return geometry::subtract(ball(0.5, 0.5, z, 0.36), {ball(0.62, 0.41, z, 0.2)}); };
  const Tree<3> t3 = refined_along<3>(bitten(0.5), 2, 6, 1.0);
  check_consistency(t3, EmbeddedGeometry<3>(t3, bitten(0.5)));
  const Tree<2> t2 = refined_along<2>(bitten(0.0), 2, 8, 1.0);
  check_consistency(t2, EmbeddedGeometry<2>(t2, bitten(0.0)));
}

TEST(EmbeddedGeometry, AnAdaptiveTreeAlongTheWallHasTheUniformTreesTotals) {
  // Every cut cell is at the finest level, so the cells differ only where they are uncut.
  const auto solid = ball(0.49, 0.53, 0.5, 0.31);
  const Tree<3> adaptive = refined_along<3>(solid, 2, 6, 2.0), uniform = uniform_tree<3>(6);
  const Totals a = totals(adaptive, EmbeddedGeometry<3>(adaptive, solid));
  const Totals u = totals(uniform, EmbeddedGeometry<3>(uniform, solid));
  EXPECT_LT(adaptive.num_leaves(), uniform.num_leaves() / 3);
  EXPECT_NEAR(a.fluid, u.fluid, 1e-13);
  EXPECT_NEAR(a.wall, u.wall, 1e-13);
}

TEST(EmbeddedGeometry, BothSidesOfAPeriodicSeamSeeOneWall) {
  // A ball on the seam x = 0 of a periodic brick, and the same ball moved half a brick (a
  // whole number of cells) into a brick without seams: the same cuts, so the same totals.
  const Tree<3> periodic = uniform_tree<3>(5, true), plain = uniform_tree<3>(5, false);
  const EmbeddedGeometry<3> on_seam(periodic, geometry::unite({ball(0.0, 0.47, 0.52, 0.23), ball(1.0, 0.47, 0.52, 0.23)}));
  const EmbeddedGeometry<3> inside(plain, ball(0.5, 0.47, 0.52, 0.23));
  const Totals a = totals(periodic, on_seam), b = totals(plain, inside);
  EXPECT_NEAR(a.fluid, b.fluid, 1e-12);
  EXPECT_NEAR(a.wall, b.wall, 1e-12);
  check_consistency(periodic, on_seam, /*adaptive=*/false);
}

TEST(EmbeddedGeometry, ARebuildAfterAnAdaptationIsAFreshEvaluationToTheBit) {
  // Walls at level 6 for x < 0.5 and 5 beyond; then the level-5 cut leaves beyond x = 0.5
  // refine (new cuts) and the level-6 leaves below x = 0.3 coarsen (cuts made before).
  const auto solid = geometry::subtract(ball(0.5, 0.5, 0.5, 0.36), {ball(0.62, 0.41, 0.5, 0.2)});
  Tree<3> t = testing::refined_by<3>(6, [&](const Eigen::Vector3d& centre, double half) {
    const bool near = std::abs(solid->signed_distance(centre)) <= half + 1.0 / 64;
    return near ? (centre[0] < 0.5 ? 6 : 5) : 2;
  });
  EmbeddedGeometry<3> g(t, solid);
  EXPECT_EQ(g.reused_cuts(), 0);
  std::vector<std::int8_t> flags(static_cast<std::size_t>(t.num_cells()), 0);
  for (const Index c : t.leaves()) {
    const int l = t.level_of(c);
    const double x = t.center(c)[0];
    if (l == 5 && x > 0.5 && g.wall_area(c) > 0.0) flags[static_cast<std::size_t>(c)] = 1;
    if (l == 6 && x < 0.3) flags[static_cast<std::size_t>(c)] = -1;
  }
  const tree::AdaptCounts counts = t.apply_flags(flags);
  ASSERT_GT(counts.refined, 0);
  ASSERT_GT(counts.coarsened, 0);
  g.rebuild();
  const EmbeddedGeometry<3> fresh(t, solid);
  EXPECT_GT(g.reused_cuts(), 0);
  EXPECT_GT(g.evaluated_cuts(), 0);
  EXPECT_EQ(g.reused_cuts() + g.evaluated_cuts(), fresh.evaluated_cuts());
  EXPECT_TRUE(std::equal(g.volume().begin(), g.volume().end(), fresh.volume().begin(), fresh.volume().end()));
  for (int d = 0; d < 3; ++d) EXPECT_EQ(g.faces()[d], fresh.faces()[d]) << "direction " << d;
  EXPECT_TRUE(
      std::equal(g.uniform().begin(), g.uniform().end(), fresh.uniform().begin(), fresh.uniform().end()));
  for (int l = 0; l <= t.depth(); ++l) {
    ASSERT_TRUE(std::ranges::equal(g.cut_cells(l), fresh.cut_cells(l))) << "level " << l;
    for (const Index c : g.cut_cells(l)) {
      ASSERT_EQ(g.wall_area(c), fresh.wall_area(c));
      ASSERT_EQ(g.wall_centroid(c), fresh.wall_centroid(c));
      ASSERT_EQ(g.wall_normal_area(c), fresh.wall_normal_area(c));
    }
  }
}

TEST(EmbeddedGeometry, CellsFarFromTheWallAreFullOrEmpty) {
  const auto solid = ball(0.5, 0.5, 0.5, 0.25);
  const Tree<3> t = uniform_tree<3>(5);
  const EmbeddedGeometry<3> g(t, solid);
  for (const Index c : t.leaves()) {
    const double phi = g.signed_distance(t.center(c));
    const double v = g.volume()[static_cast<std::size_t>(c)];
    if (phi > t.cell_size(5)) {
      EXPECT_EQ(v, 1.0);
    } else if (phi < -t.cell_size(5)) {
      EXPECT_EQ(v, 0.0);
    }
  }
  EXPECT_FALSE(g.cut_cells(5).empty());
  for (const Index c : g.cut_cells(5)) EXPECT_GT(g.wall_area(c), 0.0);
  EXPECT_TRUE(g.near_wall(t.box(g.cut_cells(5).front()), 0.0));
  EXPECT_FALSE(g.surely_solid(t.box(g.cut_cells(5).front())));
  // Far in the fluid and deep in the ball: no wall within reach.
  EXPECT_FALSE(g.near_wall({{0.0, 0.0, 0.0}, {0.1, 0.1, 0.1}}, 0.05));
  EXPECT_FALSE(g.surely_solid({{0.0, 0.0, 0.0}, {0.1, 0.1, 0.1}}));
  EXPECT_FALSE(g.near_wall({{0.45, 0.45, 0.45}, {0.55, 0.55, 0.55}}, 0.05));
  EXPECT_TRUE(g.surely_solid({{0.45, 0.45, 0.45}, {0.55, 0.55, 0.55}}));
  // The margin reaches the wall (0.25 - 0.0866 from the centre to the box's corner).
  EXPECT_TRUE(g.near_wall({{0.45, 0.45, 0.45}, {0.55, 0.55, 0.55}}, 0.2));
}

}  // namespace
}  // namespace capsflow::fluid
