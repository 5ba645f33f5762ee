#pragma once
// Personalised exchange in which each rank has words for a few others only (the node routing
// of capsules, their returned velocities and migrations): only the non-empty lists travel,
// and each rank learns who sent to it by a non-blocking consensus (Hoefler, Siebert and
// Lumsdaine, "Scalable communication protocols for dynamic sparse data exchange", PPoPP
// 2010): synchronous sends, receives of whatever arrives, and a non-blocking barrier entered
// once this rank's sends are matched. Its latency grows with the neighbours and log P, where
// all_to_all's MPI_Alltoallv exchanges with every rank (docs/parallel.md, weak-scaling model).
#include <cstdint>
#include <vector>

#include "parallel/comm.hpp"

namespace capsflow::parallel {

// send[q]: the words for rank q (comm.size() lists, most of them empty). Returns what each
// rank sent this one, by sender: the same as all_to_all(comm, send). Collective (every rank
// calls it, in the same order as the other exchanges); throws std::runtime_error naming
// the MPI call that failed.
[[nodiscard]] std::vector<std::vector<std::uint64_t>> sparse_exchange(
    const Comm& comm, const std::vector<std::vector<std::uint64_t>>& send);

}  // namespace capsflow::parallel
