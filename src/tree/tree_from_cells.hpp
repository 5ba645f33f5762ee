#pragma once
// The coarsest balanced tree in which every given cell exists: how a rank builds its local
// tree from its owned and ghost leaves (distributed_forest.hpp), and how rank 0 rebuilds the
// whole forest from the leaves every rank sends it.
#include <span>

#include "tree/curve_stencil.hpp"
#include "tree/tree.hpp"

namespace capsflow::tree {

// `cells` in curve order. Leaves are split while a given cell lies deeper inside them. Cells
// of one balanced forest come out as cells of the same level; one that is a leaf there stays
// a leaf unless a deeper given cell lies inside it. Elsewhere the leaves are as coarse as the
// 2:1 balance allows (a local tree's placeholders, Basilisk's MPI trees do the same): they are
// refined only towards a given cell or by the balance next to a finer one, so they are never
// finer than the given cells around them, and balancing never splits a given leaf.
template <int D>
[[nodiscard]] Tree<D> tree_refined_to(const TreeOptions<D>& options, std::span<const CurveCell> cells);

}  // namespace capsflow::tree
