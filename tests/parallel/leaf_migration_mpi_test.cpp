// Leaf migration on 1-4 ranks, against the serial forest every rank builds: a repartition
// with other weights moves every leaf and every value to its new owner exactly, in curve
// order, and the union is still the serial forest.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "forest_fixtures.hpp"
#include "parallel/reduce.hpp"
#include "tree/leaf_migration.hpp"

namespace capsflow::tree {
namespace {

using testing::Leaf;

// Two components per leaf, distinct for every cell.
double value_of(const CurveCell& c, int component) {
  return (component == 0 ? 1.0 : -3.0) * (static_cast<double>(c.position) * 1e-9 + c.level);
}

template <int D>
Partition split_evenly(const parallel::Comm& comm, const std::vector<Leaf>& leaves, bool by_level) {
  const auto n = leaves.size(), p = static_cast<std::size_t>(comm.size()), r = static_cast<std::size_t>(comm.rank());
  std::vector<Key> positions;
  std::vector<std::int64_t> weights;
  for (std::size_t i = n * r / p; i < n * (r + 1) / p; ++i) {
    positions.push_back(leaves[i].position);
    weights.push_back(by_level ? 1 + leaves[i].level * leaves[i].level : leaves[i].weight);
  }
  return Partition::by_weight(comm, positions, weights);
}

template <int D>
void check_migration(const TreeOptions<D>& o) {
  const parallel::Comm comm = parallel::Comm::world();
  const auto tree = testing::uneven_tree(o);
  const auto all = testing::curve_leaves(tree);
  const Partition partition = split_evenly<D>(comm, all, false);
  std::vector<CurveCell> mine;
  for (const Leaf& l : all)
    if (partition.owner(l.position) == comm.rank()) mine.push_back({l.position, l.level});
  std::vector<double> values;
  for (const CurveCell& c : mine) values.insert(values.end(), {value_of(c, 0), value_of(c, 1)});

  // Repartition with other weights: each rank ends with exactly the leaves the new partition
  // gives it, in curve order, values intact; the union is still the serial forest.
  const Partition next = split_evenly<D>(comm, all, true);
  const MigratedLeaves moved = migrate_leaves(comm, next, mine, values, 2);
  std::vector<CurveCell> owned_next;
  for (const Leaf& l : all)
    if (next.owner(l.position) == comm.rank()) owned_next.push_back({l.position, l.level});
  // EXPECT, never ASSERT, before a collective: a rank that returned early would hang the others.
  EXPECT_TRUE(std::ranges::equal(owned_next, moved.leaves));
  for (std::size_t i = 0; i < moved.leaves.size(); ++i) {
    EXPECT_EQ(moved.values[2 * i], value_of(moved.leaves[i], 0));
    EXPECT_EQ(moved.values[2 * i + 1], value_of(moved.leaves[i], 1));
  }
  EXPECT_EQ(parallel::global_sum(comm, std::int64_t(moved.leaves.size())), std::int64_t(all.size()));
}

TEST(LeafMigration, Walls2D) { check_migration<2>({.roots = {2, 1}, .max_level = 6}); }

TEST(LeafMigration, Periodic2D) { check_migration<2>({.roots = {2, 2}, .periodic = {true, false}, .max_level = 5}); }

TEST(LeafMigration, Channel3D) {
  check_migration<3>({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 4});
}

TEST(LeafMigration, TriplyPeriodic3D) {
  check_migration<3>({.roots = {1, 1, 1}, .periodic = {true, true, true}, .max_level = 4});
}

}  // namespace
}  // namespace capsflow::tree
