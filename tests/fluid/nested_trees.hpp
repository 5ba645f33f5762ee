#pragma once
// Adaptive test trees whose refinement regions are unions of cells of a fixed 1/8
// lattice, so the trees of successive max levels are nested and their resolution jumps
// stay in place (a region that follows a sphere at each resolution moves its jumps by
// O(h) and makes max-norm convergence orders noisy).
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "tree/tree.hpp"

namespace capsflow::fluid::testing {

// Unit cube/square; `rings` are (radius, levels below max) around the centre, innermost
// first; cells outside every ring are `outer_drop` levels below max.
template <int D>
tree::Tree<D> nested_ball_tree(int level, std::vector<std::pair<double, int>> rings, int outer_drop,
                               bool periodic = false) {
  tree::TreeOptions<D> o{.max_level = level};
  o.roots.fill(1);
  o.periodic.fill(periodic);
  tree::Tree<D> t(o);
  t.refine_to([=](const tree::Box<D>& b) {
    double r2 = 0.0;
    for (int d = 0; d < D; ++d) {
      const double lo = std::floor(b.lo[d] * 8 + 1e-9) / 8, hi = std::ceil(b.hi[d] * 8 - 1e-9) / 8;
      const double c = std::clamp(0.5, lo, hi) - 0.5;
      r2 += c * c;
    }
    for (const auto& [radius, drop] : rings)
      if (r2 < radius * radius) return level - drop;
    return level - outer_drop;
  });
  return t;
}

}  // namespace capsflow::fluid::testing
