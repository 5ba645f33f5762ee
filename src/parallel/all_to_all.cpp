#include "parallel/all_to_all.hpp"

#include <stdexcept>

#include <fmt/format.h>

#include "parallel/collective_counts.hpp"

namespace capsflow::parallel {

namespace {

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(fmt::format("all_to_all: {} failed (MPI error {})", what, code));
}

}  // namespace

std::vector<std::vector<std::uint64_t>> all_to_all(const parallel::Comm& comm,
                                                   const std::vector<std::vector<std::uint64_t>>& send) {
  const int p = comm.size();
  detail::count_all_to_all();
  std::vector<int> send_counts(static_cast<std::size_t>(p)), recv_counts(static_cast<std::size_t>(p));
  for (int q = 0; q < p; ++q) send_counts[static_cast<std::size_t>(q)] = static_cast<int>(send[static_cast<std::size_t>(q)].size());
  check(MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, comm.handle()), "MPI_Alltoall");
  std::vector<int> send_offsets(static_cast<std::size_t>(p), 0), recv_offsets(static_cast<std::size_t>(p), 0);
  std::vector<std::uint64_t> send_words, recv_words;
  for (int q = 0; q < p; ++q) {
    const auto u = static_cast<std::size_t>(q);
    send_offsets[u] = static_cast<int>(send_words.size());
    send_words.insert(send_words.end(), send[u].begin(), send[u].end());
    recv_offsets[u] = q == 0 ? 0 : recv_offsets[u - 1] + recv_counts[u - 1];
  }
  recv_words.resize(static_cast<std::size_t>(recv_offsets.back() + recv_counts.back()));
  check(MPI_Alltoallv(send_words.data(), send_counts.data(), send_offsets.data(), MPI_UINT64_T, recv_words.data(),
                      recv_counts.data(), recv_offsets.data(), MPI_UINT64_T, comm.handle()),
        "MPI_Alltoallv");
  std::vector<std::vector<std::uint64_t>> received(static_cast<std::size_t>(p));
  for (int q = 0; q < p; ++q) {
    const auto u = static_cast<std::size_t>(q);
    const auto first = recv_words.begin() + recv_offsets[u];
    received[u].assign(first, first + recv_counts[u]);
  }
  return received;
}

}  // namespace capsflow::parallel
