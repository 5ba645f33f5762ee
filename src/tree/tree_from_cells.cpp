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
    // A level's cells come in key order, so the first given cell at or after each leaf only
    // moves forward: a galloping search from the previous one (a binary search over all
    // cells per leaf and pass was a twentieth of a rank's time on the seed case).
    for (int l = 0; l <= t.depth(); ++l) {
      const Level<D>& lv = t.level(l);
      auto it = cells.begin();
      Key previous = 0;
      for (Index i = 0; i < lv.n_active; ++i) {
        if (!lv.leaf[static_cast<std::size_t>(i)]) continue;
        const Key begin = curve_position<D>(l, lv.keys[static_cast<std::size_t>(i)], top);
        const Key end = begin + span_of<D>(l, top);
        const CurveCell first{begin, 0};
        if (begin < previous) it = cells.begin();  // not in key order after all: search from the start
        previous = begin;
        std::size_t step = 1;
        auto low = it;
        while (it != cells.end() && curve_less(*it, first)) {
          low = it;
          it += static_cast<std::ptrdiff_t>(std::min<std::size_t>(step, static_cast<std::size_t>(cells.end() - it)));
          step *= 2;
        }
        it = std::lower_bound(low, it, first, curve_less);
        for (auto x = it; x != cells.end() && x->position < end; ++x)
          if (x->level > l) {
            flags[static_cast<std::size_t>(lv.base + i)] = 1;
            any = true;
            break;
          }
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
