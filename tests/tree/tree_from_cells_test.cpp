// tree_refined_to (one rebuild from the balanced parents of every level) against its
// definition: split every leaf that starts a deeper given cell, one level per pass, the
// balance coming with apply_flags. Random balanced forests of 2D and 3D bricks, walls and
// periodic sides, random subsets of their leaves and parents as the given cells.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "tree/radix_sort.hpp"
#include "tree/tree_from_cells.hpp"

namespace capsflow::tree {
namespace {

template <int D>
Tree<D> by_passes(const TreeOptions<D>& o, std::span<const CurveCell> cells) {
  Tree<D> t(o);
  for (int pass = 0; pass <= o.max_level; ++pass) {
    std::vector<std::int8_t> flags(static_cast<std::size_t>(t.num_cells()), 0);
    bool any = false;
    for (const Index c : t.leaves()) {
      const int l = t.level_of(c);
      const Key begin = curve_position<D>(l, morton_encode<D>(t.coords(c)), o.max_level);
      const Key end = begin + span_of<D>(l, o.max_level);
      for (const CurveCell& x : cells)
        if (x.position >= begin && x.position < end && x.level > l) {
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
std::vector<std::pair<int, Key>> leaves_of(const Tree<D>& t) {
  std::vector<std::pair<int, Key>> out;
  for (const Index c : t.leaves()) out.emplace_back(t.level_of(c), morton_encode<D>(t.coords(c)));
  std::sort(out.begin(), out.end());
  return out;
}

template <int D>
void check(const TreeOptions<D>& o, unsigned seed) {
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < 12; ++trial) {
    // A random balanced forest: level 2 everywhere, then random splits level after level.
    Tree<D> forest(o);
    (void)forest.refine_to([](const Box<D>&) { return 2; });
    for (int pass = 2; pass < o.max_level; ++pass) {
      std::vector<std::int8_t> flags(static_cast<std::size_t>(forest.num_cells()), 0);
      const unsigned percent = 10 + static_cast<unsigned>(rng() % 40);
      for (const Index c : forest.leaves())
        if (rng() % 100 < percent) flags[static_cast<std::size_t>(c)] = 1;
      (void)forest.apply_flags(flags);
    }
    // Given, as a rank's owned and ghost cells: the leaves of a stretch of the curve and a
    // random few of the other cells (leaves and parents).
    std::vector<CurveCell> cells;
    const Key whole = span_of<D>(0, o.max_level) * static_cast<Key>(forest.level(0).n_active);
    Key from = rng() % whole, to = rng() % whole;
    if (from > to) std::swap(from, to);
    const unsigned keep = static_cast<unsigned>(rng() % 10);
    for (int l = 0; l <= forest.depth(); ++l) {
      const Level<D>& lv = forest.level(l);
      for (Index i = 0; i < lv.n_active; ++i) {
        const CurveCell c{curve_position<D>(l, lv.keys[static_cast<std::size_t>(i)], o.max_level), l};
        const bool owned = lv.leaf[static_cast<std::size_t>(i)] && c.position >= from && c.position < to;
        if (owned || rng() % 100 < keep) cells.push_back(c);
      }
    }
    sort_in_curve_order(cells);
    const Tree<D> fast = tree_refined_to<D>(o, cells);
    const Tree<D> reference = by_passes<D>(o, cells);
    EXPECT_EQ(fast.num_cells(), reference.num_cells()) << "trial " << trial;
    EXPECT_EQ(leaves_of(fast), leaves_of(reference)) << "trial " << trial;
  }
}

TEST(TreeFromCells, OneRebuildIsTheTreeOfThePasses2D) { check<2>({.roots = {3, 2}, .max_level = 6}, 11); }
TEST(TreeFromCells, OneRebuildIsTheTreeOfThePassesPeriodic2D) {
  check<2>({.roots = {2, 2}, .periodic = {true, false}, .max_level = 6}, 12);
}
TEST(TreeFromCells, OneRebuildIsTheTreeOfThePasses3D) { check<3>({.roots = {2, 1, 1}, .max_level = 4}, 13); }
TEST(TreeFromCells, OneRebuildIsTheTreeOfThePassesPeriodic3D) {
  check<3>({.roots = {1, 2, 1}, .periodic = {true, true, true}, .max_level = 4}, 14);
}
TEST(TreeFromCells, NoCellsGiveTheRoots) {
  const Tree<3> t = tree_refined_to<3>({.roots = {4, 1, 1}, .max_level = 5}, {});
  EXPECT_EQ(t.num_leaves(), 4);
  EXPECT_EQ(t.depth(), 0);
}

}  // namespace
}  // namespace capsflow::tree
