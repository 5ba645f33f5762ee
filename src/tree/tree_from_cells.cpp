#include "tree/tree_from_cells.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "tree/radix_sort.hpp"

namespace capsflow::tree {

template <int D>
Tree<D> tree_refined_to(const TreeOptions<D>& o, std::span<const CurveCell> cells) {
  CAPSFLOW_ASSERT(std::is_sorted(cells.begin(), cells.end(), curve_less), "tree_refined_to: cells not in curve order");
  const int top = o.max_level;
  // The parents of each level, from the finest up: the parents of the given cells of the
  // level below, and (2:1 balance: every cell next to a parent exists) the parents of the
  // 3^D block around each parent of the level below. A child with bit b_d along axis d has
  // its block's parents at offsets {b_d - 1, b_d} from its own parent along d. One rebuild
  // then makes the tree (the passes of "split every leaf that starts a deeper given cell"
  // it replaces rebuilt the whole tree once per level).
  std::vector<std::vector<Key>> split(static_cast<std::size_t>(top) + 1);
  for (const CurveCell& c : cells)
    if (c.level > 0) split[static_cast<std::size_t>(c.level) - 1].push_back(key_of<D>(c, top) >> D);
  for (int l = top - 1; l >= 0; --l) {
    auto& parents = split[static_cast<std::size_t>(l)];
    std::array<std::int64_t, D> extent{};
    for (int d = 0; d < D; ++d) extent[d] = static_cast<std::int64_t>(o.roots[d]) << l;
    for (const Key k : split[static_cast<std::size_t>(l) + 1]) {
      const Coords<D> c = morton_decode<D>(k);
      for (unsigned corner = 0; corner < kChildren<D>; ++corner) {
        Coords<D> p{};
        bool inside = true;
        for (int d = 0; d < D; ++d) {
          std::int64_t v = (c[d] >> 1) + (c[d] & 1) - 1 + static_cast<std::int64_t>((corner >> d) & 1u);
          if (v < 0 || v >= extent[d]) {
            if (!o.periodic[d]) inside = false;  // beyond a wall: no cell
            v = ((v % extent[d]) + extent[d]) % extent[d];
          }
          p[d] = static_cast<std::int32_t>(v);
        }
        if (inside) parents.push_back(morton_encode<D>(p));
      }
    }
    radix_sort(parents, [](Key k) { return k; });
    parents.erase(std::unique(parents.begin(), parents.end()), parents.end());
  }
  Tree<D> t(o);
  t.split_cells(split);
  return t;
}

template Tree<2> tree_refined_to<2>(const TreeOptions<2>&, std::span<const CurveCell>);
template Tree<3> tree_refined_to<3>(const TreeOptions<3>&, std::span<const CurveCell>);

}  // namespace capsflow::tree
