#pragma once
// Sparse personalised exchange of variable-length lists (MPI_Alltoall of the counts, then
// MPI_Alltoallv of the words): what the tree's ghost-layer and partition constructions use
// to ask other ranks about cells and to get their answers.
#include <cstdint>
#include <vector>

#include "parallel/comm.hpp"

namespace capsflow::parallel {

// send[q]: the words for rank q (comm.size() lists). Returns what each rank sent this one,
// by sender. Collective; throws std::runtime_error naming the MPI call that failed.
[[nodiscard]] std::vector<std::vector<std::uint64_t>> all_to_all(const Comm& comm,
                                                                 const std::vector<std::vector<std::uint64_t>>& send);

}  // namespace capsflow::parallel
