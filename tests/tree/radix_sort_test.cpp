#include "tree/radix_sort.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace capsflow::tree {
namespace {

TEST(RadixSort, EqualsAComparisonSortAndKeepsTheOrderOfEqualKeys) {
  std::mt19937_64 random(7);
  // Keys of 0 to 64 bits: one digit, several, a partial last digit, the whole word.
  for (const int bits : {0, 1, 11, 12, 20, 33, 64}) {
    const std::uint64_t mask = bits == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
    std::vector<std::pair<std::uint64_t, int>> v;
    for (int i = 0; i < 5000; ++i) v.push_back({random() & mask & (i % 3 == 0 ? ~std::uint64_t{0xff} : mask), i});
    auto expected = v;
    std::stable_sort(expected.begin(), expected.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    radix_sort(v, [](const auto& x) { return x.first; });
    EXPECT_EQ(v, expected) << bits << " bits";
  }
}

TEST(RadixSort, CurveOrderIsPositionThenLevel) {
  std::mt19937_64 random(11);
  std::vector<CurveCell> cells;
  for (int i = 0; i < 4000; ++i)
    cells.push_back({random() % 512 * 8, static_cast<int>(random() % 7)});  // many equal positions
  auto expected = cells;
  std::sort(expected.begin(), expected.end(), curve_less);
  sort_in_curve_order(cells);
  EXPECT_EQ(cells, expected);
  std::vector<CurveCell> empty;
  sort_in_curve_order(empty);
  EXPECT_TRUE(empty.empty());
}

}  // namespace
}  // namespace capsflow::tree
