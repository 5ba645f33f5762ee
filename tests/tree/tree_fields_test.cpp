// Transfer between levels: exactness for linear fields, conservation, boundary cells.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "tree/prolongation.hpp"
#include "tree_invariants.hpp"

namespace capsflow::tree {
namespace {

template <int D>
double linear(const Point<D>& x) {
  double v = 0.7;
  for (int d = 0; d < D; ++d) v += (1.3 + 0.4 * d) * x[d] * (d % 2 ? -1.0 : 1.0);
  return v;
}
template <int D>
double linear_gradient(int d) {
  return (1.3 + 0.4 * d) * (d % 2 ? -1.0 : 1.0);
}

// A randomly refined, balanced tree.
template <int D>
Tree<D> random_tree(TreeOptions<D> opt, unsigned seed, int steps) {
  Tree<D> t(opt);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int s = 0; s < steps; ++s) {
    std::vector<std::int8_t> flags(t.num_cells(), 0);
    for (const Index c : t.leaves()) flags[c] = u(rng) < 0.3 ? 1 : (u(rng) < 0.3 ? -1 : 0);
    (void)t.apply_flags(flags);
  }
  return t;
}

template <int D>
void set_leaves(Tree<D>& t, std::span<double> v, double (*f)(const Point<D>&)) {
  for (const Index c : t.leaves()) v[c] = f(t.center(c));
}

TEST(ProlongationKernel, ExactForLinearAndConservative) {
  const double lo[3] = {1.0, -2.0, 0.5}, hi[3] = {3.0, 4.0, 0.5};
  for (const auto& s : {ParentSlopes<3>::linear(2.0, lo, hi), ParentSlopes<3>::limited(2.0, lo, hi)}) {
    double sum = 0.0;
    for (int b = 0; b < 8; ++b) sum += s.child(b);
    EXPECT_DOUBLE_EQ(sum / 8.0, 2.0);
    // u = 2 + x - ... along direction 0 the neighbours 1 and 3 make slope 1 per parent
    // width, so children sit at +-1/4 of it: 2 -+ 0.25 (+ other directions).
    EXPECT_DOUBLE_EQ(s.child(1) - s.child(0), 0.5);
  }
  // Limiter: at an extremum the slope vanishes.
  const double lo2[1] = {1.0}, hi2[1] = {1.0};
  EXPECT_EQ(ParentSlopes<1>::limited(2.0, lo2, hi2).child(1), 2.0);
  EXPECT_EQ(minmod(1.0, 2.0), 1.0);
  EXPECT_EQ(minmod(-3.0, -2.0), -2.0);
  EXPECT_EQ(minmod(-1.0, 2.0), 0.0);
}

// The direction-by-direction evaluation of the quadratic prolongation gives every child
// the tensor-product value, for any block (random values) in 2D and 3D.
template <int D>
void check_quadratic_children() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double block[ipow(3, D)], all[kChildren<D>];
  for (int trial = 0; trial < 20; ++trial) {
    for (double& v : block) v = u(rng);
    quadratic_children<D>(block, all);
    for (int b = 0; b < kChildren<D>; ++b) EXPECT_NEAR(all[b], quadratic_child<D>(block, b), 1e-15);
  }
}

TEST(ProlongationKernel, QuadraticChildrenDirectionByDirection) {
  check_quadratic_children<2>();
  check_quadratic_children<3>();
}

template <int D>
void check_linear_sync(TreeOptions<D> opt, unsigned seed, BcKind kind) {
  Tree<D> t = random_tree<D>(opt, seed, 6);
  ASSERT_GE(t.depth(), 3);
  std::vector<double> v(t.num_cells(), 0.0);
  set_leaves<D>(t, v, &linear<D>);
  BoundaryConditions<D> bc;
  for (int s = 0; s < 2 * D; ++s) {
    bc.side[s].kind = kind;
    if (kind == BcKind::dirichlet) {
      bc.side[s].function = [](const Point<D>& x) { return linear<D>(x); };
    } else {
      const double sign = (s & 1) ? 1.0 : -1.0;  // outward normal derivative
      bc.side[s].value = sign * linear_gradient<D>(s / 2);
    }
  }
  t.sync(v, bc, Prolongation::linear);
  double worst = 0.0;
  Index checked = 0;
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    for (Index c = lv.active_begin(); c < lv.halo_end(); ++c, ++checked)
      worst = std::max(worst, std::abs(v[c] - linear<D>(t.center(c))));
    for (const Index g : lv.boundary_fill) {
      ++checked;
      worst = std::max(worst, std::abs(v[g] - linear<D>(t.center_at(l, lv.boundary_coords[g - lv.boundary_begin()]))));
    }
  }
  EXPECT_GT(checked, t.num_leaves());
  EXPECT_LT(worst, 1e-12) << "restriction, halo prolongation and boundary cells must be exact for linear fields";
}

TEST(TreeFields, LinearFieldExactEverywhere2DDirichlet) {
  check_linear_sync<2>({.roots = {3, 2}, .root_size = 0.5, .origin = {-1, 0.25}, .max_level = 6}, 11,
                       BcKind::dirichlet);
}
TEST(TreeFields, LinearFieldExactEverywhere2DNeumann) {
  check_linear_sync<2>({.roots = {2, 2}, .max_level = 6}, 12, BcKind::neumann);
}
TEST(TreeFields, LinearFieldExactEverywhere3DDirichlet) {
  check_linear_sync<3>({.roots = {4, 1, 1}, .root_size = 2, .origin = {-4, -1, -1}, .max_level = 4}, 13,
                       BcKind::dirichlet);
}
TEST(TreeFields, LinearFieldExactEverywhere3DNeumann) {
  check_linear_sync<3>({.roots = {1, 2, 1}, .max_level = 4}, 14, BcKind::neumann);
}

double quadratic3(const Point<3>& x) {
  return 0.3 + x[0] * x[0] - 2 * x[1] * x[2] + 0.5 * x[2] * x[2] + x[0] * x[1] - x[1];
}

// Quadratic halo prolongation is exact for quadratic fields (away from walls, where the
// Dirichlet boundary cells are only second order, so use a periodic-free interior check).
TEST(TreeFields, QuadraticHaloExactForQuadratics) {
  TreeOptions<3> opt{.roots = {2, 2, 2}, .origin = {-1, -1, -1}, .max_level = 4};
  Tree<3> t = random_tree<3>(opt, 51, 5);
  std::vector<double> v(t.num_cells(), 0.0);
  // Set every active cell (not only leaves: restriction of a quadratic is not its centre
  // value) and every boundary cell exactly, then fill the halos.
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<3>& lv = t.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) v[c] = quadratic3(t.center(c));
    for (Index g = lv.boundary_begin(); g < lv.boundary_end(); ++g)
      v[g] = quadratic3(t.center_at(l, lv.boundary_coords[g - lv.boundary_begin()]));
  }
  Index halos = 0;
  for (int l = 1; l <= t.depth(); ++l) {
    t.fill_halo(l, v, Prolongation::quadratic);
    const Level<3>& lv = t.level(l);
    for (Index c = lv.halo_begin(); c < lv.halo_end(); ++c, ++halos)
      ASSERT_NEAR(v[c], quadratic3(t.center(c)), 1e-13);
  }
  EXPECT_GT(halos, 100);
}

// sync_leaf_neighbors fills only Level::halo_read: every halo or boundary value a face
// stencil of an active cell reads must still equal the full sync's, with every value the
// fill is not meant to produce poisoned (NaN propagates through any read of a stale cell).
template <int D>
void check_face_read_halo(TreeOptions<D> opt, unsigned seed, Prolongation p) {
  Tree<D> t = random_tree<D>(opt, seed, 2 * opt.max_level);
  BoundaryConditions<D> bc = BoundaryConditions<D>::all(BcKind::dirichlet);
  bc.side[1].kind = BcKind::neumann;
  std::vector<double> full(t.num_cells(), 0.0);
  std::vector<double> part(t.num_cells(), std::nan(""));
  for (const Index c : t.leaves()) full[c] = part[c] = std::sin(3.0 * t.center(c)[0]) + t.center(c)[D - 1];
  t.sync(full, bc, p);
  t.sync_leaf_neighbors(part, bc, p);
  Index read = 0, skipped = 0;
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
      // Leaves read halo and boundary neighbours (the residual); parents, halo neighbours
      // (the multigrid's relaxation; their boundary cells it fills itself).
      const Index end = lv.is_leaf(c) ? lv.boundary_end() : lv.halo_end();
      const Index* row = lv.face_row(c);
      for (int k = 0; k < 2 * D; ++k) {
        if (row[k] < lv.halo_begin() || row[k] >= end) continue;
        ASSERT_EQ(part[row[k]], full[row[k]]) << "level " << l << " cell " << c << " face " << k;
        ++read;
      }
    }
    skipped += lv.n_halo / kChildren<D> - static_cast<Index>(lv.halo_read.size());
  }
  EXPECT_GT(read, 100);
  EXPECT_GT(skipped, 0);  // the point of the list: some groups are not filled
}

TEST(TreeFields, LeafNeighborSyncFillsEveryHaloAFaceReads2D) {
  check_face_read_halo<2>({.roots = {2, 1}, .periodic = {true, false}, .max_level = 7}, 61, Prolongation::quadratic);
}
TEST(TreeFields, LeafNeighborSyncFillsEveryHaloAFaceReads3D) {
  check_face_read_halo<3>({.roots = {2, 1, 1}, .max_level = 5}, 62, Prolongation::quadratic);
  check_face_read_halo<3>({.roots = {1, 1, 2}, .periodic = {false, true, false}, .max_level = 5}, 63,
                          Prolongation::linear);
}

// A field registered with the tree is prolonged exactly when its leaves are split.
TEST(TreeFields, RefinementProlongsLinearFieldExactly) {
  TreeOptions<3> opt{.roots = {2, 1, 1}, .origin = {-1, 0, 0}, .max_level = 5};
  Tree<3> t = random_tree<3>(opt, 21, 4);
  BoundaryConditions<3> bc;
  for (auto& s : bc.side) {
    s.kind = BcKind::dirichlet;
    s.function = [](const Point<3>& x) { return linear<3>(x); };
  }
  const FieldId f = t.add_field({.name = "u", .prolongation = Prolongation::linear, .bc = bc});
  const FieldId g = t.add_field({.name = "u_limited", .prolongation = Prolongation::limited, .bc = bc});
  set_leaves<3>(t, t.values(f), &linear<3>);
  set_leaves<3>(t, t.values(g), &linear<3>);
  std::vector<std::int8_t> flags(t.num_cells(), 1);
  const Index before = t.num_leaves();
  const AdaptCounts counts = t.apply_flags(flags);
  EXPECT_GT(t.num_leaves(), before);
  EXPECT_GT(counts.refined, 0);
  for (const Index c : t.leaves()) {
    ASSERT_NEAR(t.values(f)[c], linear<3>(t.center(c)), 1e-12);
    ASSERT_NEAR(t.values(g)[c], linear<3>(t.center(c)), 1e-12);
  }
}

template <int D>
double integral(const Tree<D>& t, std::span<const double> v) {
  double sum = 0.0;
  for (const Index c : t.leaves()) sum += v[c] * std::pow(t.cell_size(t.level_of(c)), D);
  return sum;
}

// Refining then coarsening (random flags, many times) keeps the integral to round-off.
template <int D>
void check_conservation(TreeOptions<D> opt, Prolongation p, unsigned seed) {
  Tree<D> t = random_tree<D>(opt, seed, 3);
  const FieldId f = t.add_field({.name = "q", .prolongation = p});
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (const Index c : t.leaves()) t.values(f)[c] = u(rng);
  const double before = integral<D>(t, t.values(f));
  int changes = 0;
  for (int step = 0; step < 20; ++step) {
    std::vector<std::int8_t> flags(t.num_cells(), 0);
    for (const Index c : t.leaves()) flags[c] = u(rng) < -0.4 ? 1 : (u(rng) < 0.2 ? -1 : 0);
    const AdaptCounts counts = t.apply_flags(flags);
    changes += counts.refined + counts.coarsened;
  }
  EXPECT_GT(changes, 50);
  EXPECT_NEAR(integral<D>(t, t.values(f)), before, 1e-13 * t.num_leaves());
}

TEST(TreeFields, RefineCoarsenConservesIntegral2D) {
  check_conservation<2>({.roots = {2, 1}, .periodic = {true, false}, .max_level = 7}, Prolongation::linear, 31);
  check_conservation<2>({.roots = {1, 1}, .max_level = 7}, Prolongation::limited, 32);
}
TEST(TreeFields, RefineCoarsenConservesIntegral3D) {
  check_conservation<3>({.roots = {2, 1, 1}, .max_level = 4}, Prolongation::linear, 33);
  check_conservation<3>({.roots = {1, 1, 1}, .periodic = {true, true, true}, .max_level = 4},
                        Prolongation::limited, 34);
}

// Periodic sides wrap: a field periodic in x reads its wrapped neighbours.
TEST(TreeFields, PeriodicHaloWraps) {
  TreeOptions<2> opt{.roots = {2, 1}, .periodic = {true, true}, .max_level = 5};
  Tree<2> t = random_tree<2>(opt, 41, 5);
  std::vector<double> v(t.num_cells(), 0.0);
  for (const Index c : t.leaves()) v[c] = 3.0;
  t.sync(v, BoundaryConditions<2>::all(BcKind::dirichlet, 99.0));  // no boundary cells: unused
  for (int l = 0; l <= t.depth(); ++l) {
    EXPECT_EQ(t.level(l).n_boundary, 0);
    for (Index c = t.level(l).active_begin(); c < t.level(l).halo_end(); ++c) ASSERT_DOUBLE_EQ(v[c], 3.0);
  }
}

}  // namespace
}  // namespace capsflow::tree
