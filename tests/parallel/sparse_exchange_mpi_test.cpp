// The sparse exchange on 1-4 ranks: what all_to_all delivers, for patterns from empty to
// dense, over many calls in a row (a fast rank's next sends must not land in this call).
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "parallel/all_to_all.hpp"
#include "parallel/collective_counts.hpp"
#include "parallel/sparse_exchange.hpp"

namespace capsflow::parallel {
namespace {

// Rank r's lists in round `round`: each other rank gets words with probability `density`,
// their count and values from (round, r, q), so every rank can check what it received.
std::vector<std::vector<std::uint64_t>> lists(const Comm& comm, int round, double density) {
  std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm.size()));
  for (int q = 0; q < comm.size(); ++q) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(1000 * round + 10 * comm.rank() + q));
    if (std::uniform_real_distribution<double>(0, 1)(rng) >= density) continue;
    const auto n = std::uniform_int_distribution<int>(1, round % 7 == 0 ? 20000 : 40)(rng);  // some above the eager limit
    for (int i = 0; i < n; ++i) send[static_cast<std::size_t>(q)].push_back(rng());
  }
  return send;
}

TEST(SparseExchange, DeliversWhatAllToAllDelivers) {
  const Comm comm = Comm::world();
  const CollectiveCounts before = collective_counts();
  int calls = 0;
  for (int round = 0; round < 60; ++round) {
    const double density = round % 3 == 0 ? 0.0 : round % 3 == 1 ? 0.4 : 1.0;
    const auto send = lists(comm, round, density);
    const auto sparse = sparse_exchange(comm, send);
    ++calls;
    const auto dense = comm.distributed() ? all_to_all(comm, send) : send;
    ASSERT_EQ(sparse, dense) << "round " << round << " on rank " << comm.rank();
  }
  EXPECT_EQ(collective_counts().sparse_exchanges - before.sparse_exchanges, comm.distributed() ? calls : 0);
}

TEST(SparseExchange, BackToBackCallsKeepTheirMessagesApart) {
  // No collective between the calls: a rank with nothing to receive races ahead.
  const Comm comm = Comm::world();
  for (int round = 0; round < 200; ++round) {
    std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm.size()));
    const int to = (comm.rank() + 1 + round % std::max(1, comm.size() - 1)) % comm.size();
    send[static_cast<std::size_t>(to)] = {static_cast<std::uint64_t>(round), static_cast<std::uint64_t>(comm.rank())};
    const auto received = sparse_exchange(comm, send);
    for (int q = 0; q < comm.size(); ++q) {
      const auto& w = received[static_cast<std::size_t>(q)];
      if (w.empty()) continue;
      ASSERT_EQ(w.size(), 2u);
      EXPECT_EQ(w[0], static_cast<std::uint64_t>(round)) << "a message of another call";
      EXPECT_EQ(w[1], static_cast<std::uint64_t>(q));
    }
  }
}

}  // namespace
}  // namespace capsflow::parallel
