#pragma once
// The one way a value is reduced across ranks (DESIGN.md, "Distributed memory"): each rank
// reduces its own cells first (threads included), then one MPI_Allreduce combines the ranks.
// On one rank without a communicator these return the local value and make no MPI call.
//
// Sums of doubles go through ExactSum, so a norm, a volume or a flux is the same to the last
// bit on any number of ranks and threads; maxima and minima are order-independent anyway,
// and propagate NaN (a blow-up on one rank is seen by all).
#include <cstdint>

#include "parallel/comm.hpp"
#include "parallel/exact_sum.hpp"

namespace capsflow::parallel {

[[nodiscard]] double global_sum(const Comm& comm, const ExactSum& local);
[[nodiscard]] std::int64_t global_sum(const Comm& comm, std::int64_t local);
// NaN if any rank's value is NaN.
[[nodiscard]] double global_max(const Comm& comm, double local);
[[nodiscard]] double global_min(const Comm& comm, double local);
[[nodiscard]] std::int64_t global_max(const Comm& comm, std::int64_t local);
// Whether the condition holds on any rank (an error on one rank stops all).
[[nodiscard]] bool global_any(const Comm& comm, bool local);

}  // namespace capsflow::parallel
