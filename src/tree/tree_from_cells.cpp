#include "tree/tree_from_cells.hpp"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace capsflow::tree {

template <int D>
Tree<D> tree_refined_to(const TreeOptions<D>& o, std::span<const CurveCell> cells) {
  CAPSFLOW_ASSERT(std::is_sorted(cells.begin(), cells.end(), curve_less), "tree_refined_to: cells not in curve order");
  const int top = o.max_level;
  Tree<D> t(o);
  // Split every leaf that starts a given cell deeper than itself, until none does; each
  // pass goes one level down, the balance comes with apply_flags.
  std::vector<std::int8_t> flags;
  for (int pass = 0; pass <= top; ++pass) {
    flags.assign(static_cast<std::size_t>(t.num_cells()), 0);
    bool any = false;
    for (const Index c : t.leaves()) {
      const int l = t.level_of(c);
      const Level<D>& lv = t.level(l);
      const Key begin = curve_position<D>(l, lv.keys[static_cast<std::size_t>(c - lv.base)], top);
      const Key end = begin + span_of<D>(l, top);
      auto it = std::lower_bound(cells.begin(), cells.end(), CurveCell{begin, 0}, curve_less);
      for (; it != cells.end() && it->position < end; ++it)
        if (it->level > l) {
          flags[static_cast<std::size_t>(c)] = 1;
          any = true;
          break;
        }
    }
    if (!any) break;
    (void)t.apply_flags(flags);
  }
  return t;
}

template Tree<2> tree_refined_to<2>(const TreeOptions<2>&, std::span<const CurveCell>);
template Tree<3> tree_refined_to<3>(const TreeOptions<3>&, std::span<const CurveCell>);

}  // namespace capsflow::tree
