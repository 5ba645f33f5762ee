#pragma once
// How many collective calls this process has made, by kind: what the weak-scaling model
// (tools/capsule_weak_scaling_model.py) multiplies by each collective's cost at P ranks. A
// reduction's latency grows as log P; a personalised exchange's (MPI_Alltoallv, most of
// whose lists are empty) as P with Open MPI's pairwise algorithm. Counts only, no timing.
#include <cstdint>

namespace capsflow::parallel {

struct CollectiveCounts {
  std::int64_t reductions = 0;   // MPI_Allreduce through reduce.hpp and all_or_none
  std::int64_t all_to_all = 0;   // all_to_all.hpp: one MPI_Alltoall and one MPI_Alltoallv each
  std::int64_t sparse_exchanges = 0;  // sparse_exchange.hpp: messages to neighbours, one MPI_Ibarrier
};

[[nodiscard]] CollectiveCounts collective_counts();

namespace detail {
void count_reduction();
void count_all_to_all();
void count_sparse_exchange();
}  // namespace detail

}  // namespace capsflow::parallel
