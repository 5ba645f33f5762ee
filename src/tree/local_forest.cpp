#include "tree/local_forest.hpp"

#include <algorithm>
#include <stdexcept>

#include <fmt/format.h>

namespace capsflow::tree {

namespace {

// The index of cell c in the sorted list, or kNone.
Index find_cell(std::span<const CurveCell> sorted, const CurveCell& c) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), c, curve_less);
  return it != sorted.end() && *it == c ? static_cast<Index>(it - sorted.begin()) : kNone;
}

}  // namespace

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

template <int D>
LocalForest<D> build_local_forest(const TreeOptions<D>& o, std::span<const CurveCell> owned,
                                  std::span<const CurveCell> ghosts) {
  std::vector<CurveCell> real(owned.begin(), owned.end());
  real.insert(real.end(), ghosts.begin(), ghosts.end());
  std::sort(real.begin(), real.end(), curve_less);
  const int top = o.max_level;
  LocalForest<D> out{.tree = tree_refined_to<D>(o, real)};
  Tree<D>& t = out.tree;
  out.role.assign(static_cast<std::size_t>(t.num_cells()), LeafRole::remote);
  out.slot.assign(static_cast<std::size_t>(t.num_cells()), kNone);
  for (const Index c : t.leaves()) {
    const int l = t.level_of(c);
    const Level<D>& lv = t.level(l);
    const CurveCell cell{curve_position<D>(l, lv.keys[static_cast<std::size_t>(c - lv.base)], top), l};
    const auto u = static_cast<std::size_t>(c);
    if (const Index i = find_cell(owned, cell); i != kNone) {
      out.role[u] = LeafRole::owned;
      out.slot[u] = i;
      ++out.owned;
    } else if (const Index g = find_cell(ghosts, cell); g != kNone) {
      out.role[u] = LeafRole::ghost;
      out.slot[u] = g;
      ++out.ghosts;
    } else {
      ++out.remote;
    }
  }
  if (out.owned != static_cast<Index>(owned.size()) || out.ghosts != static_cast<Index>(ghosts.size()))
    throw std::logic_error(fmt::format("local forest: {} of {} owned and {} of {} ghost leaves came out as leaves "
                                       "(the inputs are not leaves of one balanced forest)",
                                       out.owned, owned.size(), out.ghosts, ghosts.size()));
  return out;
}

template Tree<2> tree_refined_to<2>(const TreeOptions<2>&, std::span<const CurveCell>);
template Tree<3> tree_refined_to<3>(const TreeOptions<3>&, std::span<const CurveCell>);
template LocalForest<2> build_local_forest<2>(const TreeOptions<2>&, std::span<const CurveCell>,
                                              std::span<const CurveCell>);
template LocalForest<3> build_local_forest<3>(const TreeOptions<3>&, std::span<const CurveCell>,
                                              std::span<const CurveCell>);

}  // namespace capsflow::tree
