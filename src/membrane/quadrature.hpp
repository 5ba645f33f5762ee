#pragma once
// Quadrature rules on the reference triangle {xi, eta >= 0, xi + eta <= 1}; the weights sum
// to 1/2, its area, so  integral f dxi deta ~= sum_q w_q f(xi_q, eta_q).
//
// - centroid_rule(): one point, degree 1 (exact for the constant integrands of P1).
// - hammer3_rule(): Hammer, Marlowe & Stroud (1956) interior 3-point rule, degree 2, the
//   rule of the seed paper for P2 elements.
// - gauss_rule(n): n x n Gauss-Legendre points on the square collapsed onto the triangle
//   (xi = u, eta = v (1 - u), Jacobian 1 - u); exact for polynomials of degree 2n - 2.
//   Computed, not tabulated, so any degree is available and the construction is checkable.
#include <vector>

namespace capsflow::membrane {

struct QuadraturePoint {
  double xi;
  double eta;
  double weight;
};

struct QuadratureRule {
  std::vector<QuadraturePoint> points;
  int degree = 0;  // polynomials of total degree <= degree are integrated exactly
};

[[nodiscard]] QuadratureRule centroid_rule();
[[nodiscard]] QuadratureRule hammer3_rule();

inline constexpr int max_gauss_points = 10;  // per direction
// The collapsed Gauss rule with n points per direction (1 <= n <= max_gauss_points), built
// once per n and shared; throws std::invalid_argument naming n when out of range.
[[nodiscard]] const QuadratureRule& gauss_rule(int n);
// Smallest collapsed Gauss rule exact for polynomials of the given total degree.
[[nodiscard]] const QuadratureRule& gauss_rule_for_degree(int degree);

}  // namespace capsflow::membrane
