#pragma once
// A rank's local tree (docs/parallel.md): a complete forest in the usual Tree format that has
// every leaf this rank owns and every ghost leaf as a leaf, and elsewhere "remote"
// placeholder leaves as coarse as the 2:1 balance allows (Basilisk's MPI trees do the same).
// The single-rank machinery (rebuild, neighbour tables, halo prolongation, level loops) then
// runs unchanged on each rank; computing loops skip what the rank does not own.
//
// Why placeholders never hide a real leaf: the owned and ghost leaves are leaves of one
// balanced global forest, so they are balanced among themselves; a placeholder is refined
// only towards a real leaf it contains or by the balance next to a finer one, so it is never
// finer than the real leaves around it, and balancing never splits a real leaf.
#include <cstdint>
#include <span>
#include <vector>

#include "tree/ghost_layer.hpp"
#include "tree/tree.hpp"

namespace capsflow::tree {

enum class LeafRole : std::uint8_t { owned, ghost, remote };

template <int D>
struct LocalForest {
  Tree<D> tree;
  std::vector<LeafRole> role;  // per cell of the tree; meaningful on leaves
  std::vector<Index> slot;     // per cell: index in the owned or ghost list, else kNone
  Index owned = 0, ghosts = 0, remote = 0;  // leaves of each role
};

// The coarsest balanced tree in which every given cell (curve order) exists: leaves are
// split while a given cell lies deeper inside them. Cells of one balanced forest come out
// as cells of the same level; one that is a leaf there stays a leaf unless a deeper given
// cell lies inside it.
template <int D>
[[nodiscard]] Tree<D> tree_refined_to(const TreeOptions<D>& options, std::span<const CurveCell> cells);

// `owned` and `ghosts` in curve order (GhostLayer::ghosts() is). Throws std::logic_error if a
// given leaf does not come out as a leaf (the inputs were not leaves of one balanced forest).
template <int D>
[[nodiscard]] LocalForest<D> build_local_forest(const TreeOptions<D>& options, std::span<const CurveCell> owned,
                                                std::span<const CurveCell> ghosts);

}  // namespace capsflow::tree
