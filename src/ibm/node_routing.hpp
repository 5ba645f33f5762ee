#pragma once
// Membrane nodes on N ranks (docs/parallel.md, "Capsules"): the owner of a capsule sends each
// of its nodes (position, force) to the ranks that own a cell of the box of max-level cells
// around it, so each of those ranks can spread the force into its own cells and interpolate
// from them; what they interpolate goes back to the owner (PartialVelocities). The ranks
// follow from the partition's split keys (tree::box_owners): no rank holds a table of cells,
// and a rank hears only of the nodes near its own cells, so nothing scales with the number
// of capsules times the number of ranks.
//
// A rank's received nodes come sorted by (capsule, node): every rank spreads them into its
// cells in that order, the order one rank uses, so each face's sum is one rank's to the bit.
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "ibm/interpolate.hpp"
#include "parallel/comm.hpp"
#include "tree/partition.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::ibm {

// The nodes of one capsule this rank owns, to be routed.
struct OutgoingNodes {
  int capsule = 0;
  const Eigen::Matrix3Xd* x = nullptr;
  const Eigen::Matrix3Xd* f = nullptr;  // nullptr: zeros (a routing for positions only)
  int reach = 0;  // half-width of the box, in max-level cells, around the cell holding a node
  // The box (inclusive, in max-level cells) of the cells a node's stencils read, inside the
  // reach above; empty: the whole reach. A node then goes to the owners of its box's cells.
  std::function<void(const double* x, tree::Coords<3>& lo, tree::Coords<3>& hi)> box;
};

struct RoutedNodes {
  struct Range {
    int capsule = 0;
    int owner = 0;  // the rank that sent them
    Eigen::Index begin = 0, end = 0;
  };
  std::vector<Range> ranges;  // capsules ascending, each once
  std::vector<std::int32_t> node;  // the node's index in its capsule, ascending within a range
  Eigen::Matrix3Xd x, f;
  // Traffic of the routing, for the benchmarks and the weak-scaling model: nodes and words
  // sent to other ranks and the ranks sent to.
  std::int64_t nodes_sent = 0, words_sent = 0;
  int ranks_sent_to = 0;
};

// Collective over comm. `level`: the tree's max level (the stencils' cells).
[[nodiscard]] RoutedNodes route_nodes(const parallel::Comm& comm, const tree::Partition& partition,
                                      const tree::TreeOptions<3>& options, int level,
                                      std::span<const OutgoingNodes> outgoing);

// What this rank interpolated for the nodes of each received range (one PartialVelocities
// per range, in order) goes back to the ranges' owners; each owner gets, for each of its
// capsules, the nodes' velocities completed in box_sum's order (complete_face_velocity).
// kernel_of(capsule) gives the capsule's interpolation kernel (kind, divergence_free);
// velocities_of(capsule) the 3 x nodes matrix to fill (positions_of(capsule) where the
// stencils were taken). Throws std::logic_error if a node's stencil was not covered
// exactly once. Collective over comm.
struct VelocityTargets {
  int capsule = 0;
  KernelKind kernel = KernelKind::cosine;
  bool divergence_free = true;
  const Eigen::Matrix3Xd* x = nullptr;  // where the stencils were taken
  Eigen::Matrix3Xd* v = nullptr;        // resized and filled
};
// Returns the words this rank sent to other ranks.
std::int64_t return_velocities(const parallel::Comm& comm, const tree::TreeOptions<3>& options, double h,
                               const RoutedNodes& routed, std::span<const PartialVelocities> partials,
                               std::span<const VelocityTargets> targets);

}  // namespace capsflow::ibm
