#pragma once
// The order in which a checkpoint stores leaves (docs/checkpoint-format.md): by level, then
// by Morton key within a level. It does not depend on how the tree was built or on the rank
// count: on N ranks each rank's owned leaves of a level are one run of that level's list
// (a part is a range of the curve, and the curve orders a level's cells by key), and the
// runs follow one another in rank order.
#include <algorithm>
#include <utility>
#include <vector>

#include "tree/tree.hpp"

namespace capsflow::tree {

template <int D>
[[nodiscard]] std::vector<Index> owned_leaves_by_key(const Tree<D>& t) {
  std::vector<std::pair<std::pair<int, Key>, Index>> keyed;
  keyed.reserve(t.owned_leaves().size());
  for (const Index c : t.owned_leaves()) {
    const int l = t.level_of(c);
    keyed.push_back({{l, t.level(l).keys[static_cast<std::size_t>(c - t.level(l).base)]}, c});
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<Index> order;
  order.reserve(keyed.size());
  for (const auto& k : keyed) order.push_back(k.second);
  return order;
}

}  // namespace capsflow::tree
