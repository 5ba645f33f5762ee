#pragma once
// The partition of a forest over MPI ranks along the Morton curve (DESIGN.md, "Distributed
// memory"; the scheme of p4est's p4est_partition).
//
// A cell's place on the curve is the Morton key, at the tree's max level, of its first
// descendant: position(l, key) = key << D (max_level - l). Leaves tile the brick, so their
// positions in increasing order are the curve, and a parent's position is its first child's.
// Rank r owns the positions [split[r], split[r+1]); split[0] = 0 and split[P] is past every
// key. Which rank owns a cell then follows from its key and the P + 1 split keys alone (a
// binary search over the ranks, never over cells), so no rank holds a table of cells, and a
// cell whose descendants span several ranks (an ancestor) belongs to the owner of its first
// descendant.
//
// Weights: leaf i with weight w_i and weight prefix s_i = sum_{j<i} w_j (over the whole
// curve) goes to rank floor(s_i P / W). The result depends only on the leaves and their
// weights, not on how they are spread over the ranks before the call, and each rank's load
// is within one leaf's weight of W / P.
#include <cstdint>
#include <span>
#include <vector>

#include "parallel/comm.hpp"
#include "tree/morton.hpp"

namespace capsflow::tree {

template <int D>
[[nodiscard]] constexpr Key curve_position(int level, Key key, int max_level) {
  return key << (D * (max_level - level));
}

class Partition {
 public:
  // Every position on rank 0 of `ranks` (the others empty): the state before the first
  // balancing, and the only partition of a serial run.
  static Partition all_on_root(int ranks = 1);
  // The weighted split of the leaves, each rank passing its own leaves' curve positions
  // (strictly increasing, and above every position of lower ranks) and positive weights.
  // Collective over comm.
  static Partition by_weight(const parallel::Comm& comm, std::span<const Key> positions,
                             std::span<const std::int64_t> weights);

  // The partition with these split keys (split[0] = 0, non-decreasing; the last past every
  // key): one every rank already agrees on, or a test's. Throws std::invalid_argument otherwise.
  static Partition from_splits(std::vector<Key> split);

  [[nodiscard]] int ranks() const { return static_cast<int>(split_.size()) - 1; }
  // The owner of a curve position.
  [[nodiscard]] int owner(Key position) const;
  // The owner of the cell (level, key) of a tree whose max level is max_level.
  template <int D>
  [[nodiscard]] int owner(int level, Key key, int max_level) const {
    return owner(curve_position<D>(level, key, max_level));
  }
  // First position owned by rank r (split[r]); split(ranks()) is past every key.
  [[nodiscard]] Key split(int r) const { return split_.at(static_cast<std::size_t>(r)); }
  [[nodiscard]] bool operator==(const Partition&) const = default;

 private:
  explicit Partition(std::vector<Key> split) : split_(std::move(split)) {}
  std::vector<Key> split_;  // ranks() + 1 entries, non-decreasing
};

}  // namespace capsflow::tree
