#pragma once
// Forests for the distributed-memory tests: the same serial forest on every rank, its leaves
// in curve order, to split and compare against.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "tree/partition.hpp"
#include "tree/tree.hpp"

namespace capsflow::tree::testing {

struct Leaf {
  Key position;
  int level;
  Key key;
  std::int64_t weight;
};

// A forest refined unevenly (deeper towards one corner, plus a pseudo-random sprinkle), its
// leaves in curve order with weights 1-4.
template <int D>
std::vector<Leaf> curve_leaves(const Tree<D>& t) {
  std::vector<Leaf> leaves;
  for (const Index c : t.leaves()) {
    const int l = t.level_of(c);
    const Level<D>& lv = t.level(l);
    const Key key = lv.keys[static_cast<std::size_t>(c - lv.base)];
    leaves.push_back({curve_position<D>(l, key, t.max_level()), l, key, 1 + static_cast<std::int64_t>(key % 4)});
  }
  std::sort(leaves.begin(), leaves.end(), [](const Leaf& a, const Leaf& b) { return a.position < b.position; });
  return leaves;
}

template <int D>
Tree<D> uneven_tree(const TreeOptions<D>& o) {
  Tree<D> t(o);
  t.refine_to([&](const Box<D>& b) {
    double s = 0.0;
    for (int d = 0; d < D; ++d) s += b.lo[d] - o.origin[d];
    const auto hash = static_cast<unsigned>(1000 * (b.lo[0] + 3 * b.hi[D - 1])) % 7u;
    return s < 0.6 * o.root_size ? o.max_level : (hash == 0 ? o.max_level - 1 : 2);
  });
  return t;
}

}  // namespace capsflow::tree::testing
