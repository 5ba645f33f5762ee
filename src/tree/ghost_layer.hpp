#pragma once
// The ghost layer of a partitioned forest: the remote leaves that this rank's stencils read,
// and the one call that brings their values (DESIGN.md, "Distributed memory"; p4est's
// p4est_ghost and AMReX's FillBoundary play these roles there).
//
// Definition. A stencil of a leaf M of level m reads the cells of level m within `width`
// cells of M along every axis (faces, edges and corners; across periodic sides). The ghost
// layer of a rank is every remote leaf that overlaps one of those cells for one of its own
// leaves: a remote leaf that is coarser than the cell contains it, finer ones tile it (a
// restriction then gives the cell's value). The width covers the widest stencil that runs on
// the tree: 2 for the fluid, the multigrid and quadratic prolongation at resolution jumps,
// more for the immersed-boundary kernels.
//
// Construction (collective). Each rank asks the owners of its stencil cells (from the split
// keys alone: Partition::owner) for the leaves that overlap them; each owner answers with
// those of its leaves, its "mirrors" for that rank, in curve order. The two-sided list is then
// fixed until the next adapt or repartition, and exchange() sends mirror values straight into
// the receiver's ghost slots with no keys on the wire.
#include <cstdint>
#include <span>
#include <vector>

#include "parallel/comm.hpp"
#include "tree/curve_stencil.hpp"
#include "tree/partition.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::tree {

template <int D>
class GhostLayer {
 public:
  // Collective over comm. `leaves`: this rank's leaves (those the partition gives it) in
  // curve order.
  GhostLayer(const parallel::Comm& comm, const Partition& partition, const TreeOptions<D>& options,
             std::span<const CurveCell> leaves, int width);

  // The remote leaves, in curve order (so grouped by owner, ranks ascending).
  [[nodiscard]] std::span<const CurveCell> ghosts() const { return ghosts_; }
  // Fills ghost_values (components values per ghost, cell-major) from the owners'
  // leaf_values (components per leaf, in the order the leaves were given). Collective:
  // non-blocking sends and receives with every neighbour rank, then one wait.
  void exchange(const parallel::Comm& comm, std::span<const double> leaf_values, std::span<double> ghost_values,
                int components = 1) const;

  // Traffic of one exchange of one component, for the benchmarks and the weak-scaling model.
  [[nodiscard]] std::int64_t mirrors_sent() const;
  [[nodiscard]] int neighbour_ranks() const { return static_cast<int>(peers_.size()); }

 private:
  struct Peer {
    int rank;
    std::vector<std::int32_t> mirrors;       // local leaf indices sent, in the receiver's order
    std::int32_t ghost_begin = 0, ghost_end = 0;  // slots received from that rank
  };
  std::vector<Peer> peers_;  // ranks ascending
  std::vector<CurveCell> ghosts_;
};

extern template class GhostLayer<2>;
extern template class GhostLayer<3>;

}  // namespace capsflow::tree
