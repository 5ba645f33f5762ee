#pragma once
// HDF5 checkpoints: everything a run needs to continue exactly where it stopped — the
// tree's leaf set, the leaf values of every registered field, named extra arrays (the
// membrane state) and the time-stepping scalars. The layout is in docs/checkpoint-format.md
// and reads with h5dump.
//
// Restart protocol: the caller builds the tree from the case (roots only) and registers
// the same fields (with their boundary conditions, which live in code, not in the file),
// then read_checkpoint refines that tree until its leaves are the checkpoint's, restores the
// leaf values bit for bit, and syncs each field (restriction, halo, ghosts) as adapt() does.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "io/errors.hpp"
#include "parallel/comm.hpp"
#include "tree/distributed_forest.hpp"
#include "tree/tree.hpp"

namespace capsflow::io {

struct CheckpointScalars {
  double time = 0.0;
  std::int64_t step = 0;
  double dt = 0.0;
  bool operator==(const CheckpointScalars&) const = default;
};

// A named array of doubles with its shape (row-major, last index fastest).
struct ExtraArray {
  std::string name;
  std::vector<std::size_t> shape;
  std::vector<double> values;
  bool operator==(const ExtraArray&) const = default;
};

// What the restarting run expects of a checkpoint beyond its tree and fields (the case's
// end time, its capsules); read_checkpoint checks the file against it before it changes
// anything.
struct CheckpointExpectations {
  double t_end = std::numeric_limits<double>::infinity();  // time.t_end of the case
  // The node count of each capsule, in order, when the run knows its capsules (a case
  // without capsules: empty); unset, the capsule extras are not checked.
  std::optional<std::vector<std::size_t>> capsule_nodes;
};

// Values per leaf that live outside the tree's fields (the projected faces): this rank's
// owned leaves' rows, in tree::owned_leaves_by_key order, per_leaf values each. Written as
// /extras/<name> of shape (leaves, per_leaf) in the file's leaf order.
struct LeafArray {
  std::string name;
  std::size_t per_leaf = 1;
  std::vector<double> values;
};

struct RestoredState {
  CheckpointScalars scalars;
  std::vector<ExtraArray> extras;  // in name order
};

// Writes atomically (temporary file, then rename). On N ranks (a distributed tree) every
// rank writes its own leaves' rows into the one file, collectively (parallel HDF5), and rank
// 0 the extras (the other ranks' `extras` are ignored; `leaf_arrays` must name the same
// arrays on every rank); the file is the one a single rank would write. Throws
// std::invalid_argument for a field or extra name that is empty, contains '/', or repeats,
// or an extra or leaf array whose size does not match; std::runtime_error naming the file
// if HDF5 cannot write it (on every rank alike on N ranks).
template <int D>
void write_checkpoint(const std::filesystem::path& path, const tree::Tree<D>& tree,
                      const CheckpointScalars& scalars, std::span<const ExtraArray> extras = {},
                      std::span<const LeafArray> leaf_arrays = {});

// Restores `tree` (which must still be its bare roots, with the fields registered) from
// the checkpoint. The whole file is checked before the tree changes; each failure throws
// CheckpointError, one line naming the file and what is wrong: not a readable HDF5 file
// (missing, truncated, corrupt), a dataset that fails its checksum, not a capsflow
// checkpoint, a missing or malformed dataset, another dimension, other roots / root size /
// origin / periodicity, leaves deeper than the tree's max_level, a leaf set that is not a
// balanced tree on these roots, other field names, a time that is not finite or outside
// [0, expect.t_end), a negative step, a dt that is not finite and > 0, a non-finite field
// or extra value, other capsules than expect.capsule_nodes. Throws std::invalid_argument
// if `tree` has been refined already.
template <int D>
[[nodiscard]] RestoredState read_checkpoint(const std::filesystem::path& path, tree::Tree<D>& tree,
                                            const CheckpointExpectations& expect = {});

// A restart on N ranks: the checkpoint's state, the plan of this rank's part, and the per-leaf
// extras named by the caller as this rank's owned leaves' rows (LeafArray's order; an extra
// the file lacks is absent).
template <int D>
struct DistributedRestart {
  RestoredState state;  // scalars and the other extras, read by every rank
  std::unique_ptr<tree::DistributedForest<D>> forest;
  std::vector<LeafArray> leaf_arrays;
};

// read_checkpoint on the ranks of comm (more than one): each rank reads its share of the
// leaves' rows (versions 1 and 2, whose checksums chain through the bytes in order: the whole
// file), the leaves go to their owners under the partition tree::distribute gives them, and
// `tree` becomes this rank's local tree of `forest` with the leaf values restored and synced.
// The same checks as read_checkpoint (the leaf set's tiling and 2:1 balance checked across the
// ranks), and every rank throws the same CheckpointError. `leaf_arrays`: the extras that hold
// one row per leaf (LeafArray). Collective.
template <int D>
[[nodiscard]] DistributedRestart<D> read_checkpoint_distributed(const parallel::Comm& comm,
                                                                const std::filesystem::path& path, tree::Tree<D>& tree,
                                                                const CheckpointExpectations& expect,
                                                                std::span<const std::string> leaf_arrays);

extern template void write_checkpoint<2>(const std::filesystem::path&, const tree::Tree<2>&,
                                         const CheckpointScalars&, std::span<const ExtraArray>,
                                         std::span<const LeafArray>);
extern template void write_checkpoint<3>(const std::filesystem::path&, const tree::Tree<3>&,
                                         const CheckpointScalars&, std::span<const ExtraArray>,
                                         std::span<const LeafArray>);
extern template RestoredState read_checkpoint<2>(const std::filesystem::path&, tree::Tree<2>&,
                                                 const CheckpointExpectations&);
extern template RestoredState read_checkpoint<3>(const std::filesystem::path&, tree::Tree<3>&,
                                                 const CheckpointExpectations&);

}  // namespace capsflow::io
