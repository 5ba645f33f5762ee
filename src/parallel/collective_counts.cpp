#include "parallel/collective_counts.hpp"

#include <atomic>

namespace capsflow::parallel {

namespace {
// MPI is called from one thread per rank; relaxed atomics keep a stray OpenMP caller honest.
std::atomic<std::int64_t> reductions{0}, exchanges{0}, sparse{0};
}  // namespace

CollectiveCounts collective_counts() {
  return {.reductions = reductions.load(std::memory_order_relaxed),
          .all_to_all = exchanges.load(std::memory_order_relaxed),
          .sparse_exchanges = sparse.load(std::memory_order_relaxed)};
}

namespace detail {
void count_reduction() { reductions.fetch_add(1, std::memory_order_relaxed); }
void count_all_to_all() { exchanges.fetch_add(1, std::memory_order_relaxed); }
void count_sparse_exchange() { sparse.fetch_add(1, std::memory_order_relaxed); }
}  // namespace detail

}  // namespace capsflow::parallel
