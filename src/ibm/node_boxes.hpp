#pragma once
// The max-level cells around each membrane node, found once per step: a coupled step reads
// the same stencils three times (spreading at X*, then J(X*) u^n and J(X*) u^(n+1)), each
// as three face stencils per node, all inside one box of W + 1 cells per axis around the
// node. Locating a box in the tree (find_box: anchor searches and descents) was most of the
// spreading's and the interpolation's time (docs/parallel.md, "Stencil boxes"); the stages
// now copy their stencils' cells out of the node's box.
//
// A box this rank cannot complete (a cell missing, beyond a wall, or not a max-level leaf)
// is marked, and the stages find that node's stencils themselves: a stencil inside the box
// may still be complete, and if it is not, their own search names the missing cell.
#include <span>
#include <vector>

#include <Eigen/Core>

#include "ibm/kernels.hpp"
#include "ibm/stencil.hpp"

namespace capsflow::ibm {

class NodeBoxes {
 public:
  // For each node of x, the box covering the three face stencils of every kernel in `kinds`
  // (divergence-free or not), on the tree's max level; cells of positions outside `own`
  // are kNone. Valid while the tree and x stay as they are (checked builds compare every
  // stencil's cells with the tree's keys).
  void find(const tree::Tree<3>& t, Eigen::Ref<const Eigen::Matrix3Xd> x, std::span<const KernelKind> kinds,
            bool divergence_free, const OwnedPositions& own = {});
  // Fills cells[slot] for the stencil st of node i (slot order of BoxStencil) from its box;
  // false when the box is incomplete (then cells is untouched).
  [[nodiscard]] bool stencil_cells(Eigen::Index i, const BoxStencil& st, Index* cells) const;
  [[nodiscard]] Eigen::Index nodes() const { return static_cast<Eigen::Index>(complete_.size()); }
  void clear();

 private:
  static constexpr int kMaxCells = kMaxBoxWidth * kMaxBoxWidth * kMaxBoxWidth;
  int stride_ = 0;                           // cells per node: the widest box's
  std::vector<tree::Coords<3>> first_;       // per node
  std::vector<std::array<int, 3>> widths_;   // per node
  std::vector<std::uint8_t> complete_;       // per node
  std::vector<Index> cells_;                 // stride_ per node, slot order
  const tree::Tree<3>* tree_ = nullptr;      // what the boxes were found in (checked builds)
};

}  // namespace capsflow::ibm
