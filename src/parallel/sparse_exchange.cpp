#include "parallel/sparse_exchange.hpp"

#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "parallel/collective_counts.hpp"

namespace capsflow::parallel {

namespace {

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(fmt::format("sparse_exchange: {} failed (MPI error {})", what, code));
}

// Two tags, alternating: a rank may start the next exchange's sends while a slower rank still
// receives in this one (the barrier only says every rank has entered it), never two ahead.
constexpr int kTags[2] = {7900, 7901};

}  // namespace

std::vector<std::vector<std::uint64_t>> sparse_exchange(const Comm& comm,
                                                        const std::vector<std::vector<std::uint64_t>>& send) {
  const int p = comm.size(), me = comm.rank();
  if (static_cast<int>(send.size()) != p)
    throw std::invalid_argument(fmt::format("sparse_exchange: {} lists for {} ranks", send.size(), p));
  std::vector<std::vector<std::uint64_t>> received(static_cast<std::size_t>(p));
  received[static_cast<std::size_t>(me)] = send[static_cast<std::size_t>(me)];
  if (!comm.distributed()) return received;
  // Calls on a communicator, the same count on each of its ranks (every rank makes every call).
  static std::map<MPI_Comm, std::int64_t> calls;
  const int tag = kTags[calls[comm.handle()]++ % 2];
  detail::count_sparse_exchange();

  std::vector<MPI_Request> sends;
  for (int q = 0; q < p; ++q) {
    const auto& words = send[static_cast<std::size_t>(q)];
    if (q == me || words.empty()) continue;
    sends.emplace_back();
    check(MPI_Issend(words.data(), static_cast<int>(words.size()), MPI_UINT64_T, q, tag, comm.handle(), &sends.back()),
          "MPI_Issend");
  }
  MPI_Request barrier = MPI_REQUEST_NULL;
  bool in_barrier = false;
  for (;;) {
    int arrived = 0;
    MPI_Status status;
    check(MPI_Iprobe(MPI_ANY_SOURCE, tag, comm.handle(), &arrived, &status), "MPI_Iprobe");
    if (arrived) {
      int count = 0;
      check(MPI_Get_count(&status, MPI_UINT64_T, &count), "MPI_Get_count");
      auto& words = received[static_cast<std::size_t>(status.MPI_SOURCE)];
      words.resize(static_cast<std::size_t>(count));
      check(MPI_Recv(words.data(), count, MPI_UINT64_T, status.MPI_SOURCE, tag, comm.handle(), MPI_STATUS_IGNORE),
            "MPI_Recv");
      continue;
    }
    if (!in_barrier) {
      int matched = 0;  // every synchronous send has met its receive
      check(MPI_Testall(static_cast<int>(sends.size()), sends.data(), &matched, MPI_STATUSES_IGNORE), "MPI_Testall");
      if (matched) {
        check(MPI_Ibarrier(comm.handle(), &barrier), "MPI_Ibarrier");
        in_barrier = true;
      }
    } else {
      int done = 0;
      check(MPI_Test(&barrier, &done, MPI_STATUS_IGNORE), "MPI_Test");
      if (done) break;
    }
  }
  return received;
}

}  // namespace capsflow::parallel
