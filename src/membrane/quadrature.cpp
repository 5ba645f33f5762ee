// Quadrature rules on the reference triangle (quadrature.hpp).
#include "membrane/quadrature.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace capsflow::membrane {

namespace {

// Gauss-Legendre nodes and weights on [0, 1] by Newton iteration on P_n (Golub-Welsch would
// also do; Newton from the Chebyshev guesses converges to round-off in a few steps).
void gauss_legendre01(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(static_cast<std::size_t>(n), 0.0);
  w.assign(static_cast<std::size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) {
    double t = std::cos(std::numbers::pi * (i + 0.75) / (n + 0.5));
    double dp = 0.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = t;  // P_0, P_1
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * t * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (t * p1 - p0) / (t * t - 1.0);
      const double step = p1 / dp;
      t -= step;
      if (std::abs(step) < 1e-16) break;
    }
    // Recompute the derivative at the converged root for the weight.
    double p0 = 1.0, p1 = t;
    for (int k = 2; k <= n; ++k) {
      const double p2 = ((2 * k - 1) * t * p1 - (k - 1) * p0) / k;
      p0 = p1;
      p1 = p2;
    }
    dp = n * (t * p1 - p0) / (t * t - 1.0);
    x[static_cast<std::size_t>(i)] = 0.5 * (1.0 - t);
    w[static_cast<std::size_t>(i)] = 1.0 / ((1.0 - t * t) * dp * dp);  // 2/((1-t^2)P'^2) / 2
  }
}

QuadratureRule build_gauss_rule(int n) {
  std::vector<double> x, w;
  gauss_legendre01(n, x, w);
  QuadratureRule rule;
  rule.degree = 2 * n - 2;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double u = x[static_cast<std::size_t>(i)], v = x[static_cast<std::size_t>(j)];
      rule.points.push_back(
          {u, v * (1.0 - u), w[static_cast<std::size_t>(i)] * w[static_cast<std::size_t>(j)] * (1.0 - u)});
    }
  return rule;
}

}  // namespace

QuadratureRule centroid_rule() { return {{{1.0 / 3.0, 1.0 / 3.0, 0.5}}, 1}; }

QuadratureRule hammer3_rule() {
  const double w = 1.0 / 6.0;
  return {{{1.0 / 6.0, 1.0 / 6.0, w}, {2.0 / 3.0, 1.0 / 6.0, w}, {1.0 / 6.0, 2.0 / 3.0, w}}, 2};
}

const QuadratureRule& gauss_rule(int n) {
  static const std::array<QuadratureRule, max_gauss_points> rules = [] {
    std::array<QuadratureRule, max_gauss_points> r;
    for (int k = 1; k <= max_gauss_points; ++k) r[static_cast<std::size_t>(k - 1)] = build_gauss_rule(k);
    return r;
  }();
  if (n < 1 || n > max_gauss_points)
    throw std::invalid_argument("gauss_rule: " + std::to_string(n) +
                                " points per direction is out of range 1.." +
                                std::to_string(max_gauss_points));
  return rules[static_cast<std::size_t>(n - 1)];
}

const QuadratureRule& gauss_rule_for_degree(int degree) {
  if (degree < 0 || degree > 2 * max_gauss_points - 2)
    throw std::invalid_argument("gauss_rule_for_degree: degree " + std::to_string(degree) +
                                " is out of range 0.." + std::to_string(2 * max_gauss_points - 2));
  return gauss_rule(std::max(1, (degree + 3) / 2));
}

}  // namespace capsflow::membrane
