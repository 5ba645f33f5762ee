// The Morton-curve partition on 1-4 ranks: loads within one leaf's weight of the mean, owners
// non-decreasing along the curve, ancestors owned with their first descendant, and the same
// split whatever the distribution of the leaves before the call.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "parallel/reduce.hpp"
#include "tree/partition.hpp"
#include "tree/tree.hpp"
#include "forest_fixtures.hpp"

namespace capsflow::tree {
namespace {

using testing::Leaf;
using testing::curve_leaves;
using testing::uneven_tree;

// Rank r passes the leaves [begin(r), begin(r+1)) of the curve; `skew` moves most to rank 0.
Partition split_from(const parallel::Comm& comm, const std::vector<Leaf>& leaves, bool skew) {
  const auto n = leaves.size();
  const auto p = static_cast<std::size_t>(comm.size());
  auto begin = [&](std::size_t r) { return skew ? (r == 0 ? 0 : n - (p - r) * (n / (4 * p))) : n * r / p; };
  const auto r = static_cast<std::size_t>(comm.rank());
  std::vector<Key> positions;
  std::vector<std::int64_t> weights;
  for (std::size_t i = begin(r); i < (r + 1 == p ? n : begin(r + 1)); ++i) {
    positions.push_back(leaves[i].position);
    weights.push_back(leaves[i].weight);
  }
  return Partition::by_weight(comm, positions, weights);
}

template <int D>
void check_partition(const TreeOptions<D>& o) {
  const parallel::Comm comm = parallel::Comm::world();
  const Tree<D> t = uneven_tree(o);
  const auto leaves = curve_leaves(t);
  const Partition even = split_from(comm, leaves, false);
  const Partition skewed = split_from(comm, leaves, true);
  EXPECT_EQ(even, skewed) << "the split depends on where the leaves were before";
  ASSERT_EQ(even.ranks(), comm.size());

  std::vector<std::int64_t> load(static_cast<std::size_t>(comm.size()), 0);
  std::int64_t total = 0, heaviest = 0;
  int previous = 0;
  for (const Leaf& leaf : leaves) {
    const int r = even.owner<D>(leaf.level, leaf.key, t.max_level());
    EXPECT_GE(r, previous) << "owners must not decrease along the curve";  // (no ASSERT before a collective)
    previous = r;
    load[static_cast<std::size_t>(r)] += leaf.weight;
    total += leaf.weight;
    heaviest = std::max(heaviest, leaf.weight);
    // Every ancestor belongs to the owner of its first descendant.
    Key key = leaf.key;
    for (int l = leaf.level; l > 0 && (key & ((Key{1} << D) - 1)) == 0; --l) {
      key >>= D;
      EXPECT_EQ(even.owner<D>(l - 1, key, t.max_level()), r);
    }
  }
  EXPECT_EQ(even.owner(0), 0);
  const double mean = double(total) / comm.size();
  for (const std::int64_t w : load) EXPECT_LE(std::abs(double(w) - mean), double(heaviest)) << "unbalanced";
  // The leaves this rank owns, counted here, are its share of the 64-bit global count.
  std::int64_t mine = 0;
  for (const Leaf& leaf : leaves) mine += even.owner<D>(leaf.level, leaf.key, t.max_level()) == comm.rank();
  EXPECT_EQ(parallel::global_sum(comm, mine), static_cast<std::int64_t>(leaves.size()));
}

TEST(Partition, WeightedSplitOfAnUnevenForest2D) {
  check_partition<2>({.roots = {2, 1}, .root_size = 1.0, .max_level = 6});
}

TEST(Partition, WeightedSplitOfAnUnevenForest3D) {
  check_partition<3>({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 5});
}

TEST(Partition, MoreRanksThanLeavesLeavesSomeEmpty) {
  const parallel::Comm comm = parallel::Comm::world();
  std::vector<Key> positions;
  std::vector<std::int64_t> weights;
  if (comm.rank() == 0) {  // one heavy leaf at position 0, nothing else
    positions.push_back(0);
    weights.push_back(5);
  }
  const Partition p = Partition::by_weight(comm, positions, weights);
  EXPECT_EQ(p.owner(0), 0);
  EXPECT_EQ(p.owner(Key{1} << 40), 0);
}

}  // namespace
}  // namespace capsflow::tree
