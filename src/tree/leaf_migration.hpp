#pragma once
// Repartition: every leaf, with its values, moves to the rank that owns it under a new
// partition (DESIGN.md, "Distributed memory"). Leaves are in curve order on every rank and
// partitions are contiguous ranges of the curve, so each rank sends one contiguous run of
// its leaves to each new owner, and receives runs that, taken by sender rank, are again in
// curve order. The values arrive bit for bit.
#include <span>
#include <vector>

#include "parallel/comm.hpp"
#include "tree/curve_stencil.hpp"
#include "tree/partition.hpp"

namespace capsflow::tree {

struct MigratedLeaves {
  std::vector<CurveCell> leaves;  // this rank's leaves under the new partition, curve order
  std::vector<double> values;     // components values per leaf, cell-major
};

// Collective. `leaves` in curve order, `values` components per leaf.
[[nodiscard]] MigratedLeaves migrate_leaves(const parallel::Comm& comm, const Partition& target,
                                            std::span<const CurveCell> leaves, std::span<const double> values,
                                            int components);

}  // namespace capsflow::tree
