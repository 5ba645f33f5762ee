// Quadrature rules on the reference triangle: exact to their stated degree, and no more.
#include "membrane/quadrature.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

namespace capsflow::membrane {
namespace {

// integral over the reference triangle of xi^a eta^b = a! b! / (a + b + 2)!
double exact_monomial(int a, int b) {
  return std::tgamma(a + 1) * std::tgamma(b + 1) / std::tgamma(a + b + 3);
}

double apply(const QuadratureRule& rule, int a, int b) {
  double s = 0.0;
  for (const auto& p : rule.points) s += p.weight * std::pow(p.xi, a) * std::pow(p.eta, b);
  return s;
}

void expect_exact_to_degree(const QuadratureRule& rule, const char* name) {
  double worst_above = 0.0;
  for (int d = 0; d <= rule.degree + 1; ++d)
    for (int a = 0; a <= d; ++a) {
      const double exact = exact_monomial(a, d - a);
      const double error = std::abs(apply(rule, a, d - a) - exact) / exact;
      if (d <= rule.degree) EXPECT_LT(error, 1e-13) << name << " monomial xi^" << a << " eta^" << d - a;
      else worst_above = std::max(worst_above, error);
    }
  EXPECT_GT(worst_above, 1e-10) << name << " is exact beyond its stated degree " << rule.degree;
  for (const auto& p : rule.points) {
    EXPECT_GE(p.xi, 0.0);
    EXPECT_GE(p.eta, 0.0);
    EXPECT_LE(p.xi + p.eta, 1.0);
    EXPECT_GT(p.weight, 0.0);
  }
}

TEST(membrane_quadrature, RulesAreExactToTheirDegree) {
  expect_exact_to_degree(centroid_rule(), "centroid");
  EXPECT_EQ(centroid_rule().degree, 1);
  expect_exact_to_degree(hammer3_rule(), "Hammer 3");
  EXPECT_EQ(hammer3_rule().degree, 2);
  for (int n = 1; n <= max_gauss_points; ++n) {
    EXPECT_EQ(gauss_rule(n).degree, 2 * n - 2);
    EXPECT_EQ(gauss_rule(n).points.size(), static_cast<std::size_t>(n * n));
    expect_exact_to_degree(gauss_rule(n), "collapsed Gauss");
  }
  for (int d = 0; d <= 2 * max_gauss_points - 2; ++d) EXPECT_GE(gauss_rule_for_degree(d).degree, d);
}

TEST(membrane_quadrature, OutOfRangeNamesTheValue) {
  try {
    (void)gauss_rule(0);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("gauss_rule: 0 points"));
  }
  try {
    (void)gauss_rule_for_degree(40);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("degree 40"));
  }
}

}  // namespace
}  // namespace capsflow::membrane
