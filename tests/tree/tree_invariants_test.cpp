// Random refinement and coarsening sequences keep every invariant of the forest, and a
// change with nothing to do is the identity.
#include <gtest/gtest.h>

#include <array>
#include <random>
#include <vector>

#include "tree_invariants.hpp"

namespace capsflow::tree {
namespace {

using testing::check_invariants;

// What an idle adapt must leave as it was: every level's cells (keys, counts) and every
// field value on every slot.
template <int D>
struct Snapshot {
  std::vector<std::vector<Key>> keys;
  std::vector<std::array<Index, 3>> counts;  // active, halo, boundary per level
  std::vector<std::vector<double>> values;

  explicit Snapshot(Tree<D>& t) {
    for (int l = 0; l <= t.depth(); ++l) {
      keys.push_back(t.level(l).keys);
      counts.push_back({t.level(l).n_active, t.level(l).n_halo, t.level(l).n_boundary});
    }
    for (FieldId f = 0; f < t.num_fields(); ++f) {
      t.sync(f);  // parents, halos and boundary cells as an adapt leaves them
      values.emplace_back(t.values(f).begin(), t.values(f).end());
    }
  }
  bool operator==(const Snapshot&) const = default;
};

// p4est's test_balance2: balancing a balanced forest changes nothing. Here balance is part
// of every change, so "balance again" is a change with nothing requested: all-zero flags,
// and an adapt with no criterion, no forced level and no coarsening. Both must keep the
// cells and the field values bit for bit.
template <int D>
void expect_idle_changes_nothing(Tree<D>& t) {
  const Snapshot<D> before(t);
  const std::vector<std::int8_t> zeros(t.num_cells(), 0);
  AdaptCounts counts = t.apply_flags(zeros);
  EXPECT_EQ(counts.refined, 0);
  EXPECT_EQ(counts.coarsened, 0);
  EXPECT_TRUE(Snapshot<D>(t) == before) << "apply_flags with no flags changed the forest or a field";
  counts = t.adapt({.allow_coarsening = false});
  EXPECT_EQ(counts.refined, 0);
  EXPECT_EQ(counts.coarsened, 0);
  EXPECT_TRUE(Snapshot<D>(t) == before) << "adapt with nothing to do changed the forest or a field";
}

template <int D>
void random_sequence(TreeOptions<D> opt, unsigned seed, int steps, double p_refine, double p_coarsen) {
  Tree<D> t(opt);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  // A field with random values, carried through every change (linear prolongation).
  const FieldId f = t.add_field({.name = "random"});
  check_invariants(t);
  int max_depth = 0;
  for (int step = 0; step < steps; ++step) {
    std::vector<std::int8_t> flags(t.num_cells(), 0);
    for (const Index c : t.leaves()) {
      const double r = u(rng);
      flags[c] = r < p_refine ? 1 : (r < p_refine + p_coarsen ? -1 : 0);
    }
    const AdaptCounts counts = t.apply_flags(flags);
    EXPECT_EQ(counts.leaves, t.num_leaves());
    max_depth = std::max(max_depth, t.depth());
    SCOPED_TRACE("step " + std::to_string(step));
    check_invariants(t);
    if (::testing::Test::HasFatalFailure()) return;
    for (const Index c : t.leaves()) t.values(f)[c] = u(rng);
    expect_idle_changes_nothing(t);
  }
  EXPECT_GE(max_depth, 3) << "the sequence should reach deep levels to test anything";
}

TEST(TreeInvariants, Random2DWalls) {
  TreeOptions<2> o{.roots = {3, 2}, .root_size = 0.5, .origin = {-1.0, 0.25}, .max_level = 6};
  random_sequence<2>(o, 1, 40, 0.25, 0.5);
}

TEST(TreeInvariants, Random2DPeriodic) {
  TreeOptions<2> o{.roots = {2, 1}, .periodic = {true, true}, .max_level = 6};
  random_sequence<2>(o, 2, 40, 0.25, 0.5);
}

TEST(TreeInvariants, Random2DMixed) {
  TreeOptions<2> o{.roots = {1, 3}, .periodic = {true, false}, .max_level = 5};
  random_sequence<2>(o, 3, 30, 0.3, 0.4);
}

TEST(TreeInvariants, Random3DWalls) {
  TreeOptions<3> o{.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 4};
  random_sequence<3>(o, 4, 12, 0.15, 0.5);
}

TEST(TreeInvariants, Random3DPeriodic) {
  TreeOptions<3> o{.roots = {1, 1, 1}, .periodic = {true, true, true}, .max_level = 4};
  random_sequence<3>(o, 5, 12, 0.2, 0.5);
}

TEST(TreeInvariants, Random3DMixed) {
  TreeOptions<3> o{.roots = {2, 1, 1}, .periodic = {true, false, false}, .max_level = 4};
  random_sequence<3>(o, 6, 12, 0.2, 0.4);
}

// Refining everything to a uniform level gives exactly the uniform grid.
TEST(TreeInvariants, UniformRefinementCounts) {
  TreeOptions<3> o{.roots = {4, 1, 1}, .max_level = 3};
  Tree<3> t(o);
  t.refine_to([](const Box<3>&) { return 3; });
  EXPECT_EQ(t.num_leaves(), 4 * 512);
  EXPECT_EQ(t.depth(), 3);
  EXPECT_EQ(t.level(3).n_halo, 0);
  check_invariants(t);
}

}  // namespace
}  // namespace capsflow::tree
