// The reduction helper on 1-4 ranks: the same bits as the serial sum of all terms, NaN kept.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "parallel/all_to_all.hpp"
#include "parallel/collective_counts.hpp"
#include "parallel/reduce.hpp"

namespace capsflow::parallel {
namespace {

// The same 10 000 terms on every rank; rank r sums the terms i with i % size == r.
std::vector<double> terms() {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> m(-1.0, 1.0);
  std::uniform_int_distribution<int> e(-40, 40);
  std::vector<double> xs(10000);
  for (auto& x : xs) x = std::ldexp(m(rng), e(rng));
  return xs;
}

TEST(Reduce, ExactSumIsTheSerialSumBitForBit) {
  const Comm comm = Comm::world();
  const auto xs = terms();
  ExactSum all, mine;
  for (std::size_t i = 0; i < xs.size(); ++i) {
    all.add(xs[i]);
    if (static_cast<int>(i % static_cast<std::size_t>(comm.size())) == comm.rank()) mine.add(xs[i]);
  }
  EXPECT_EQ(global_sum(comm, mine), all.value());
}

// The counts the weak-scaling model multiplies: one per collective call that reaches MPI (on
// one rank without a distributed communicator, none), the same on every rank.
TEST(Reduce, CollectivesAreCountedOncePerCall) {
  const Comm comm = Comm::world();
  const CollectiveCounts before = collective_counts();
  (void)global_sum(comm, std::int64_t{1});
  (void)global_max(comm, 1.0);
  (void)global_any(comm, false);
  (void)all_to_all(comm, std::vector<std::vector<std::uint64_t>>(static_cast<std::size_t>(comm.size())));
  const CollectiveCounts after = collective_counts();
  EXPECT_EQ(after.reductions - before.reductions, comm.distributed() ? 3 : 0);
  EXPECT_EQ(after.all_to_all - before.all_to_all, 1);
  EXPECT_EQ(global_sum(comm, after.reductions), comm.size() * after.reductions) << "every rank counts alike";
  EXPECT_EQ(global_max(comm, after.reductions), after.reductions) << "every rank counts alike";
}

TEST(Reduce, IntegerSumMaxAndAny) {
  const Comm comm = Comm::world();
  const std::int64_t n = comm.size();
  EXPECT_EQ(global_sum(comm, std::int64_t{comm.rank() + 1}), n * (n + 1) / 2);
  EXPECT_EQ(global_max(comm, std::int64_t{comm.rank()} << 40), (n - 1) << 40);  // 64-bit counts
  EXPECT_EQ(global_max(comm, double(comm.rank())), double(n - 1));
  EXPECT_EQ(global_min(comm, double(comm.rank()) - 0.5), -0.5);
  EXPECT_TRUE(global_any(comm, comm.rank() == comm.size() - 1));
  EXPECT_FALSE(global_any(comm, false));
}

TEST(Reduce, MaxAndMinKeepNaNFromAnyRank) {
  const Comm comm = Comm::world();
  for (int bad = 0; bad < comm.size(); ++bad) {
    const double v = comm.rank() == bad ? std::nan("") : double(comm.rank());
    EXPECT_TRUE(std::isnan(global_max(comm, v))) << "NaN on rank " << bad;
    EXPECT_TRUE(std::isnan(global_min(comm, v))) << "NaN on rank " << bad;
  }
}

}  // namespace
}  // namespace capsflow::parallel
