#pragma once
// A rank's part of a forest partitioned along the Morton curve (docs/parallel.md): the
// local tree it computes on, and the plan that fills its ghost cells from their owners.
//
// Ownership. Rank r owns the cells whose curve position lies in [split[r], split[r+1])
// (partition.hpp): its leaves, and every ancestor whose first descendant is one of them.
// The owner of any cell follows from its key and the split keys alone.
//
// Ghost cells, level by level. Every solver on the tree reads, from a cell of level l, cells
// of level l within 2 of it (fluid faces, BCG slopes, multigrid relaxation), the parent's
// 3^D block (restriction, prolongation, halo filling, wavelets) and, at a resolution jump,
// the children of a neighbour. So this rank asks, at each level l, for the cells within
// `width` (2) cells of
//   (a) the level-l cells it owns,
//   (b) the parents of the level-(l+1) cells it owns,
//   (c) and for the children of the cells within one cell of its leaves of level l-1,
// that exist in the global forest and that another rank owns. Each owner answers which of
// the asked cells exist (a leaf, a parent or none) and keeps, per asking rank, the list of
// those it will send ("mirrors"); the two lists are in the same curve order, so an exchange
// sends values only, no keys.
//
// The local tree (tree_refined_to) is the coarsest balanced tree holding the owned leaves,
// the ghost cells and the first child of every ghost parent: a leaf of the global forest
// comes out a leaf, a parent a parent, and elsewhere placeholder cells nobody reads. The
// solvers run on the whole local tree unchanged ("compute everywhere, then exchange"):
// owned cells read only owned or ghost cells, which hold their owners' values after each
// exchange, so an owned cell computes what one rank computes; reductions take the owned
// leaves only.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "parallel/comm.hpp"
#include "tree/curve_stencil.hpp"
#include "tree/partition.hpp"
#include "tree/tree.hpp"

namespace capsflow::tree {

// Cells of a level within this many cells of every cell a rank owns are ghosts (above).
inline constexpr int kGhostWidth = 2;
// Coarse levels of at most this many cells per rank (and this many in all) are held whole
// by every rank (replicated()).
inline constexpr std::int64_t kReplicatedCellsPerRank = 64;
inline constexpr std::int64_t kReplicatedCellsMax = 32768;

// The load a leaf puts on its rank, for the partition: a positive integer from the leaf's
// level and Morton key (1 for every leaf unless set; a capsule can weight the cells its
// membrane crosses, whose spreading and interpolation cost several times a fluid cell's).
using LeafWeight = std::function<std::int64_t(int level, Key key)>;

template <int D>
class DistributedForest final : public Distribution, public DistributedAdaptation<D> {
 public:
  // Collective over comm. owned_leaves: the leaves of one balanced forest that `partition`
  // gives this rank, in curve order.
  DistributedForest(const parallel::Comm& comm, const Partition& partition, const TreeOptions<D>& options,
                    std::span<const CurveCell> owned_leaves, int width = kGhostWidth);

  // A new local tree for this plan (register the fields, fill them, then attach()).
  [[nodiscard]] Tree<D> make_tree() const;
  // Binds the plan to t, a tree made by make_tree(): local indices of every ghost and
  // mirror, the owned mask; t's distribution is then this. Collective.
  void attach(Tree<D>& t);

  // Distribution
  void exchange(int level, Fields fields) const override;
  void exchange_colour(int level, std::span<double> v, int colour) const override;
  void exchange_all(Fields fields) const override;
  double sum(const parallel::ExactSum& local) const override;
  double max(double local) const override;
  std::int64_t sum(std::int64_t local) const override;
  std::int64_t max(std::int64_t local) const override;
  bool replicated(int level) const override;

  // DistributedAdaptation (Tree::adapt on a distributed tree calls it with the flags of the
  // leaves it owns): the ranks agree on the decision, iterating "exchange the flags, decide
  // with the tree's own balance, keep what decided the owned leaves" until no rank's owned
  // leaves change (flags only move from merge to keep to split, so it ends); a merge is its
  // parent's owner's decision. The new leaves get their values as one rank's adapt would
  // give them (prolongation, volume mean), are repartitioned by weight (leaf_migration),
  // and t becomes the local tree of the new plan, ghosts exchanged.
  AdaptCounts adapt(Tree<D>& t, int min_level) override;

  // The weight every later partition gives a leaf (adapt(), rebalance()); empty: 1 each.
  // Every rank sets the same function.
  void set_leaf_weight(LeafWeight weight) { weight_ = std::move(weight); }
  // Repartitions the current leaves by their weights (after the weights changed) and
  // migrates every field of t, bit for bit; t becomes the local tree of the new plan.
  // Collective.
  void rebalance(Tree<D>& t);
  // The weight of the leaves this rank owns.
  [[nodiscard]] std::int64_t owned_weight() const;

  // The whole forest on rank 0: its leaves and every field's values on them (the other
  // slots zero; sync before reading them). Empty on the other ranks. Collective.
  [[nodiscard]] std::optional<Tree<D>> gather_on_root(const Tree<D>& local) const;

  [[nodiscard]] const parallel::Comm& comm() const { return comm_; }
  [[nodiscard]] const Partition& partition() const { return partition_; }
  [[nodiscard]] std::span<const CurveCell> owned_leaves() const { return owned_; }

  // Traffic, for the benchmarks and the weak-scaling model.
  struct Traffic {
    std::int64_t ghost_cells = 0;      // received by one exchange of every level
    std::int64_t mirror_cells = 0;     // sent by one exchange of every level
    std::int64_t messages = 0;         // sent by one exchange of every level
    std::vector<std::int64_t> ghosts_per_level, messages_per_level;
    std::vector<std::int64_t> exchanges_per_level;  // exchange() calls so far (with peers)
    std::vector<std::int64_t> colour_exchanges_per_level;  // exchange_colour() calls (one colour)
    std::int64_t whole_exchanges = 0;  // exchange_all() calls, each one message per peer
    std::int64_t whole_exchange_fields = 0;  // the fields they carried, summed
  };
  [[nodiscard]] Traffic traffic() const;
  // Seconds spent in MPI_Waitall and MPI_Allgatherv (of which in the one-colour exchanges
  // of the relaxation), in the reductions (MPI_Allreduce: they wait for the slowest rank
  // too), and values sent, since construction.
  [[nodiscard]] double seconds_waiting() const { return waiting_; }
  [[nodiscard]] double seconds_waiting_colour() const { return waiting_colour_; }
  [[nodiscard]] double seconds_reducing() const { return reducing_; }
  [[nodiscard]] std::int64_t reductions() const { return reductions_; }
  [[nodiscard]] std::int64_t values_sent() const { return values_sent_; }

 private:
  struct PeerCells {
    int rank = 0;
    std::vector<CurveCell> send, receive;  // curve order
  };
  struct Peer {
    int rank = 0;
    std::vector<Index> send, receive;  // local indices
    // The same lists split by red-black colour (both sides split the same curve-ordered
    // lists by the same rule, so they stay matched).
    std::array<std::vector<Index>, 2> send_colour, receive_colour;
  };
  // One message per peer of `peers` with the lists `pick` gives, every field's values one
  // field after the other.
  template <class Pick>
  void exchange_lists(std::span<const Peer> peers, int tag, Fields fields, Pick pick) const;
  // Checked builds, after attach(): the send and receive lists agree on both sides and no
  // stencil of an owned cell reaches a placeholder (p4est checks its ghost layer so).
  // Collective.
  void check_plan(const Tree<D>& t) const;
  // Builds the plan for these owned leaves (the constructor's work, again after an adapt).
  void plan(const Partition& partition, std::span<const CurveCell> owned_leaves);
  // The weight of each of these leaves.
  [[nodiscard]] std::vector<std::int64_t> weights_of(std::span<const CurveCell> leaves) const;
  // The tail of adapt() and rebalance(): `leaves` (this rank's, curve order) with `values`
  // (every field of t per leaf) go to their owners under the weighted partition, and t
  // becomes the local tree of the new plan, ghosts exchanged.
  void repartition(Tree<D>& t, std::span<const CurveCell> leaves, std::vector<double> values);
  LeafWeight weight_;
  int width_ = kGhostWidth;
  int replicated_levels_ = 0;  // levels [0, replicated_levels_) are replicated
  // A replicated level is filled by one MPI_Allgatherv (log P latencies, not P - 1
  // messages): this rank's owned cells of the level, and every rank's block unpacked into
  // the local cells it names (rank order; this rank's own block is skipped).
  struct Gather {
    std::vector<Index> send;
    std::vector<Index> receive;       // all ranks' cells, rank order (own block: kNone)
    std::vector<int> counts, offsets;  // per rank
  };
  // Every rank's block, every field's values one field after the other.
  void gather(const Gather& g, Fields fields) const;
  std::vector<Gather> gathers_;  // per replicated level
  mutable std::vector<double> gather_send_, gather_receive_;
  mutable std::vector<int> gather_counts_, gather_offsets_;
  // exchange_all(): every replicated level in one gather, and per peer the lists of every
  // distributed level one after the other (ranks ascending).
  Gather whole_gather_;
  std::vector<Peer> whole_peers_;
  parallel::Comm comm_;
  Partition partition_;
  TreeOptions<D> options_;
  std::vector<CurveCell> owned_;
  std::vector<CurveCell> required_;      // the local tree's defining cells, curve order
  std::vector<PeerCells> peer_cells_;    // ranks ascending
  std::vector<std::vector<Peer>> level_peers_;  // per level, ranks ascending
  mutable std::vector<std::vector<double>> send_buffers_, receive_buffers_;
  mutable std::vector<MPI_Request> requests_;
  mutable double waiting_ = 0.0, waiting_colour_ = 0.0, reducing_ = 0.0;
  mutable std::int64_t reductions_ = 0;
  // f() timed into reducing_.
  template <class F>
  auto timed_reduction(F&& f) const;
  mutable std::vector<std::int64_t> exchanges_, colour_exchanges_;  // per level
  mutable std::int64_t whole_exchanges_ = 0, whole_exchange_fields_ = 0;
  mutable std::int64_t values_sent_ = 0;
};

// Replaces t, the same whole forest (cells, fields, values) on every rank, by this rank's
// local tree for a partition by leaf weight (1 each if weight is empty; the plan keeps the
// function for later partitions), every field carried; returns the plan that t now points
// to (keep it alive as long as t). Collective.
template <int D>
[[nodiscard]] std::unique_ptr<DistributedForest<D>> distribute(const parallel::Comm& comm, Tree<D>& t,
                                                               LeafWeight weight = {});

extern template class DistributedForest<2>;
extern template class DistributedForest<3>;

}  // namespace capsflow::tree
