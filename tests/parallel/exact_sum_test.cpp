// ExactSum: exact identities, correct rounding, and independence of the order of the terms.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "parallel/exact_sum.hpp"

namespace capsflow::parallel {
namespace {

double sum_of(std::initializer_list<double> xs) {
  ExactSum s;
  for (const double x : xs) s.add(x);
  return s.value();
}

TEST(ExactSum, CancellationIsExact) {
  EXPECT_EQ(sum_of({1e100, 1.0, -1e100}), 1.0);
  EXPECT_EQ(sum_of({0.1, 0.2, -0.1, -0.2}), 0.0);
  EXPECT_EQ(sum_of({1e308, 1e308, -1e308}), 1e308);  // no overflow inside the accumulator
  EXPECT_EQ(sum_of({}), 0.0);
  EXPECT_EQ(sum_of({-3.5}), -3.5);
}

TEST(ExactSum, SubnormalsAndExtremes) {
  const double tiny = std::numeric_limits<double>::denorm_min();
  EXPECT_EQ(sum_of({tiny, tiny, tiny}), 3 * tiny);
  EXPECT_EQ(sum_of({std::numeric_limits<double>::max(), -std::numeric_limits<double>::max(), tiny}), tiny);
  EXPECT_EQ(sum_of({std::numeric_limits<double>::min(), -tiny}), std::numeric_limits<double>::min() - tiny);
}

TEST(ExactSum, RoundsOnceToNearestEven) {
  const double u = std::ldexp(1.0, -53);  // half an ulp of 1
  EXPECT_EQ(sum_of({1.0, u}), 1.0);                                 // tie: to even
  EXPECT_EQ(sum_of({1.0 + 2 * u, u}), 1.0 + 4 * u);                  // tie: to even (up)
  EXPECT_EQ(sum_of({1.0, u, std::ldexp(1.0, -200)}), 1.0 + 2 * u);   // above the tie: up
  EXPECT_EQ(sum_of({1.0, u, -std::ldexp(1.0, -200)}), 1.0);          // below the tie: down
  // Naive left-to-right summation gives 0 here; the exact sum is 2^-200.
  EXPECT_EQ(sum_of({1.0, std::ldexp(1.0, -200), -1.0}), std::ldexp(1.0, -200));
}

TEST(ExactSum, NonFiniteTerms) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(std::isnan(sum_of({1.0, std::nan("")})));
  EXPECT_TRUE(std::isnan(sum_of({inf, -inf})));
  EXPECT_EQ(sum_of({inf, 1.0}), inf);
  EXPECT_EQ(sum_of({-inf, 1.0}), -inf);
}

// The same terms in any order, and split into partial sums merged in any grouping, give
// the same bits; the value agrees with a long double sum of the terms sorted by magnitude.
TEST(ExactSum, IndependentOfOrderAndGrouping) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-30, 30);
  std::vector<double> xs(20000);
  for (auto& x : xs) x = std::ldexp(mantissa(rng), exponent(rng));
  ExactSum reference;
  reference.add(xs);
  const double expected = reference.value();
  for (int trial = 0; trial < 5; ++trial) {
    std::shuffle(xs.begin(), xs.end(), rng);
    ExactSum whole;
    whole.add(xs);
    EXPECT_EQ(whole.value(), expected);
    ExactSum parts[3];
    for (std::size_t i = 0; i < xs.size(); ++i) parts[(i * 7 + static_cast<std::size_t>(trial)) % 3].add(xs[i]);
    parts[2].add(parts[0]);
    parts[2].add(parts[1]);
    EXPECT_EQ(parts[2].value(), expected);
    EXPECT_EQ(ExactSum::from_words(parts[2].words()).value(), expected);
  }
  std::sort(xs.begin(), xs.end(), [](double a, double b) { return std::fabs(a) < std::fabs(b); });
  long double naive = 0;
  for (const double x : xs) naive += x;
  EXPECT_NEAR(expected, static_cast<double>(naive), 1e-12 * std::fabs(expected));
}

// The wire format adds element-wise: the words of a + b are the words of a plus those of b.
TEST(ExactSum, WordsAddElementWise) {
  ExactSum a, b;
  a.add(-1.25e-3);
  a.add(3e200);
  b.add(7.0);
  b.add(-3e200);
  const auto wa = a.words(), wb = b.words();
  std::array<std::int64_t, ExactSum::kWords> w{};
  for (int i = 0; i < ExactSum::kWords; ++i) w[i] = wa[i] + wb[i];
  EXPECT_EQ(ExactSum::from_words(w).value(), 7.0 - 1.25e-3);
}

}  // namespace
}  // namespace capsflow::parallel
