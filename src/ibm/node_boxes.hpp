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
//
// On N ranks each node's interpolation is made by one rank, the owner of its box's centre
// cell: every cell of a box lies within kGhostWidth cells of its centre (boxes of at most 5
// cells per axis), so that rank holds each of them, owned or as a ghost whose value is its
// owner's, and sums the whole stencil in one rank's order. The other ranks the node is
// routed to (they own cells of it) spread into their own cells and interpolate nothing.
// Wider boxes (wider kernels) are interpolated by parts, every rank sending its own cells'
// values (PartialVelocities).
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "ibm/kernels.hpp"
#include "ibm/stencil.hpp"

namespace capsflow::ibm {

// The box of max-level cells covering the three face stencils of every kernel in `kinds`
// (divergence-free or not) of the node at x: its lowest cell and widths (unwrapped across
// periodic sides). NodeBoxes finds these boxes; the routing sends a node to their owners.
struct NodeBox {
  tree::Coords<3> first{};
  std::array<int, 3> widths{};
};
[[nodiscard]] NodeBox node_box(const tree::TreeOptions<3>& o, double h, const double* x,
                               std::span<const KernelKind> kinds, bool divergence_free);

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
  // Who interpolates node i (above): every rank alike on one rank (`parts`: each rank its
  // own cells), this rank, or another.
  enum class Interpolator : std::uint8_t { parts, here, elsewhere };
  [[nodiscard]] Interpolator interpolator(Eigen::Index i) const { return interpolator_[static_cast<std::size_t>(i)]; }
  // As stencil_cells, with every cell of the stencil (owned or ghost) of a node interpolated
  // here; false when the box is incomplete or the node is not interpolated here.
  [[nodiscard]] bool held_stencil_cells(Eigen::Index i, const BoxStencil& st, Index* cells) const;
  [[nodiscard]] Eigen::Index nodes() const { return static_cast<Eigen::Index>(complete_.size()); }
  void clear();

 private:
  static constexpr int kMaxCells = kMaxBoxWidth * kMaxBoxWidth * kMaxBoxWidth;
  int stride_ = 0;                           // cells per node: the widest box's
  std::vector<tree::Coords<3>> first_;       // per node
  std::vector<std::array<int, 3>> widths_;   // per node
  std::vector<std::uint8_t> complete_;       // per node
  std::vector<Index> cells_;                 // stride_ per node, slot order
  std::vector<Interpolator> interpolator_;   // per node
  std::vector<std::uint8_t> held_complete_;  // per node interpolated here
  std::vector<std::uint8_t> held_in_owned_;  // per node: every cell of the box owned (cells_ is it)
  std::vector<Index> held_cells_;            // stride_ per node interpolated here: every cell
  // Copies st's cells out of a node's box.
  static void copy_stencil(const Index* box, const tree::Coords<3>& lo, const std::array<int, 3>& w,
                           const BoxStencil& st, Index* cells);
  const tree::Tree<3>* tree_ = nullptr;      // what the boxes were found in (checked builds)
};

}  // namespace capsflow::ibm
