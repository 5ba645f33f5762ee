// The ghost layer and leaf migration on 1-4 ranks, against the serial forest every rank
// builds: ghosts are exactly the remote leaves that some stencil of a local leaf overlaps
// (checked geometrically, not with the curve arithmetic under test), every ghost holds the
// owner's value after an exchange, and a repartition moves every leaf and value exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "forest_fixtures.hpp"
#include "parallel/reduce.hpp"
#include "tree/ghost_layer.hpp"
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

// Whether the leaf s lies within `width` cells (of m's level) of the leaf m, periodic sides
// wrapped; integer boxes at the max level.
template <int D>
bool within_reach(const TreeOptions<D>& o, const Leaf& m, const Leaf& s, int width) {
  const int top = o.max_level;
  const auto cm = morton_decode<D>(m.key), cs = morton_decode<D>(s.key);
  for (int d = 0; d < D; ++d) {
    const std::int64_t size_m = std::int64_t{1} << (top - m.level), size_s = std::int64_t{1} << (top - s.level);
    const std::int64_t lo_m = cm[d] * size_m - width * size_m, hi_m = (cm[d] + 1) * size_m + width * size_m;
    const std::int64_t extent = static_cast<std::int64_t>(o.roots[d]) << top;
    bool overlap = false;
    for (int k = o.periodic[d] ? -1 : 0; k <= (o.periodic[d] ? 1 : 0); ++k) {
      const std::int64_t lo_s = cs[d] * size_s + k * extent, hi_s = lo_s + size_s;
      overlap = overlap || (lo_s < hi_m && lo_m < hi_s);
    }
    if (!overlap) return false;
  }
  return true;
}

template <int D>
void check_ghosts_and_migration(const TreeOptions<D>& o, int width) {
  const parallel::Comm comm = parallel::Comm::world();
  const auto tree = testing::uneven_tree(o);
  const auto all = testing::curve_leaves(tree);
  const Partition partition = split_evenly<D>(comm, all, false);
  std::vector<Leaf> mine_full;
  std::vector<CurveCell> mine;
  for (const Leaf& l : all)
    if (partition.owner(l.position) == comm.rank()) {
      mine_full.push_back(l);
      mine.push_back({l.position, l.level});
    }

  const GhostLayer<D> ghosts(comm, partition, o, mine, width);
  // Exactly the remote leaves within reach of a local leaf.
  std::vector<CurveCell> expected;
  for (const Leaf& s : all) {
    if (partition.owner(s.position) == comm.rank()) continue;
    if (std::any_of(mine_full.begin(), mine_full.end(), [&](const Leaf& m) { return within_reach(o, m, s, width); }))
      expected.push_back({s.position, s.level});
  }
  // EXPECT, never ASSERT, before a collective: a rank that returned early would hang the others.
  EXPECT_TRUE(std::ranges::equal(expected, ghosts.ghosts())) << "rank " << comm.rank() << ": " << ghosts.ghosts().size()
                                                              << " ghosts, " << expected.size() << " expected";
  if (comm.size() > 1) {
    EXPECT_GT(parallel::global_sum(comm, std::int64_t(ghosts.ghosts().size())), 0);
  }

  // Every ghost holds its owner's values after one exchange.
  std::vector<double> values;
  for (const CurveCell& c : mine) values.insert(values.end(), {value_of(c, 0), value_of(c, 1)});
  std::vector<double> ghost_values(2 * ghosts.ghosts().size(), std::nan(""));
  ghosts.exchange(comm, values, ghost_values, 2);
  for (std::size_t g = 0; g < ghosts.ghosts().size(); ++g) {
    EXPECT_EQ(ghost_values[2 * g], value_of(ghosts.ghosts()[g], 0));
    EXPECT_EQ(ghost_values[2 * g + 1], value_of(ghosts.ghosts()[g], 1));
  }
  // Messages match sends: what all ranks send is what all ranks receive.
  EXPECT_EQ(parallel::global_sum(comm, ghosts.mirrors_sent()),
            parallel::global_sum(comm, std::int64_t(ghosts.ghosts().size())));

  // Repartition with other weights: each rank ends with exactly the leaves the new partition
  // gives it, in curve order, values intact; the union is still the serial forest.
  const Partition next = split_evenly<D>(comm, all, true);
  const MigratedLeaves moved = migrate_leaves(comm, next, mine, values, 2);
  std::vector<CurveCell> owned_next;
  for (const Leaf& l : all)
    if (next.owner(l.position) == comm.rank()) owned_next.push_back({l.position, l.level});
  EXPECT_TRUE(std::ranges::equal(owned_next, moved.leaves));
  for (std::size_t i = 0; i < moved.leaves.size(); ++i) {
    EXPECT_EQ(moved.values[2 * i], value_of(moved.leaves[i], 0));
    EXPECT_EQ(moved.values[2 * i + 1], value_of(moved.leaves[i], 1));
  }
  EXPECT_EQ(parallel::global_sum(comm, std::int64_t(moved.leaves.size())), std::int64_t(all.size()));
}

TEST(GhostLayer, WallsWidthOne2D) { check_ghosts_and_migration<2>({.roots = {2, 1}, .max_level = 6}, 1); }

TEST(GhostLayer, PeriodicWidthTwo2D) {
  check_ghosts_and_migration<2>({.roots = {2, 2}, .periodic = {true, false}, .max_level = 5}, 2);
}

TEST(GhostLayer, ChannelWidthTwo3D) {
  check_ghosts_and_migration<3>({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 4}, 2);
}

TEST(GhostLayer, TriplyPeriodicWidthThree3D) {
  check_ghosts_and_migration<3>({.roots = {1, 1, 1}, .periodic = {true, true, true}, .max_level = 4}, 3);
}

}  // namespace
}  // namespace capsflow::tree
