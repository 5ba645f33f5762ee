#include "tree/partition.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "parallel/collective_counts.hpp"
#include "parallel/reduce.hpp"

namespace capsflow::tree {

namespace {

__extension__ typedef __int128 I128;  // weight prefix times the rank count

constexpr Key kEnd = std::numeric_limits<Key>::max();  // past every key (keys use <= 63 bits)

void check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(fmt::format("partition: {} failed (MPI error {})", what, code));
}

}  // namespace

Partition Partition::all_on_root(int ranks) {
  if (ranks < 1) throw std::invalid_argument(fmt::format("partition: {} ranks", ranks));
  std::vector<Key> split(static_cast<std::size_t>(ranks) + 1, kEnd);
  split[0] = 0;
  return Partition(std::move(split));
}

Partition Partition::from_splits(std::vector<Key> split) {
  if (split.size() < 2 || split.front() != 0 || !std::is_sorted(split.begin(), split.end()))
    throw std::invalid_argument("partition: split keys must start at 0 and not decrease (at least one rank)");
  return Partition(std::move(split));
}

int Partition::owner(Key position) const {
  // The last rank whose first position is <= position; empty ranks share their successor's
  // split, and upper_bound skips past them to the rank that owns the position.
  const auto first = split_.begin(), last = split_.end() - 1;
  return static_cast<int>(std::upper_bound(first, last, position) - first) - 1;
}

Partition Partition::by_weight(const parallel::Comm& comm, std::span<const Key> positions,
                               std::span<const std::int64_t> weights) {
  if (positions.size() != weights.size())
    throw std::invalid_argument(fmt::format("partition: {} positions but {} weights", positions.size(), weights.size()));
  std::int64_t local = 0;
  for (std::size_t i = 0; i < weights.size(); ++i) {
    if (weights[i] <= 0) throw std::invalid_argument(fmt::format("partition: weight {} of leaf {}", weights[i], i));
    if (i > 0 && positions[i] <= positions[i - 1])
      throw std::invalid_argument(fmt::format("partition: positions not increasing at leaf {}", i));
    local += weights[i];
  }
  const int ranks = comm.size();
  std::int64_t before = 0;  // the weight on lower ranks
  if (comm.distributed()) {
    check(MPI_Exscan(&local, &before, 1, MPI_INT64_T, MPI_SUM, comm.handle()), "MPI_Exscan");
    if (comm.rank() == 0) before = 0;  // MPI leaves rank 0's result undefined
  }
  const std::int64_t total = parallel::global_sum(comm, local);
  if (total == 0) return all_on_root(ranks);

  // Each rank proposes, for every rank q, the first of its leaves that goes to q; the
  // smallest proposal over all ranks is q's split.
  std::vector<Key> split(static_cast<std::size_t>(ranks) + 1, kEnd);
  std::int64_t prefix = before;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const auto q = static_cast<std::size_t>(static_cast<I128>(prefix) * ranks / total);
    split[q] = std::min(split[q], positions[i]);
    prefix += weights[i];
  }
  if (comm.distributed()) {
    parallel::detail::count_reduction();
    check(MPI_Allreduce(MPI_IN_PLACE, split.data(), ranks, MPI_UINT64_T, MPI_MIN, comm.handle()), "MPI_Allreduce");
  }
  split[0] = 0;  // rank 0 starts the curve, whatever its first leaf
  for (int q = ranks - 1; q >= 1; --q) split[q] = std::min(split[q], split[q + 1]);  // empty ranks
  return Partition(std::move(split));
}

}  // namespace capsflow::tree
