#pragma once
// Point kernels of the transfer between levels (pure functions, testable without a tree).
//
// A parent P of size H has children of size H/2 whose centres sit at x_P + s_d H/4 with
// s_d = -1 or +1 (child bit 0 or 1 along d). Second-order prolongation evaluates the
// linear reconstruction of P from its face neighbours at the child centre:
//   linear:  u_c = u_P + sum_d s_d (u_{P+e_d} - u_{P-e_d}) / 8        (central slope)
//   limited: u_c = u_P + sum_d s_d minmod(u_{P+e_d} - u_P, u_P - u_{P-e_d}) / 4
// Both are exact for linear fields and conserve the parent's mean (the s_d cancel in pairs).
//   quadratic: tensor-product Lagrange interpolation through the parent's 3^D block at
//              xi_d = s_d / 4 (weights xi(xi-1)/2, 1 - xi^2, xi(xi+1)/2). Exact for
//              quadratics, not conservative: for halo values, where the fine cells' fluxes
//              need a third-order value for the scheme to stay second order at a
//              resolution jump (Johansen & Colella 1998).
// Restriction is the volume average of the 2^D children.
#include <array>
#include <cmath>

#include "tree/morton.hpp"
#include "tree/stencil.hpp"

namespace capsflow::tree {

constexpr double minmod(double a, double b) {
  if (a * b <= 0.0) return 0.0;
  return (a > 0.0) == (a < b) ? a : b;
}

// Slopes (per child half-offset, i.e. already multiplied by H/4 / H) of the parent along
// each direction, from its value and face neighbours.
template <int D>
struct ParentSlopes {
  double value = 0.0;
  double slope[D] = {};

  static ParentSlopes linear(double p, const double* lo, const double* hi) {
    ParentSlopes s;
    s.value = p;
    for (int d = 0; d < D; ++d) s.slope[d] = (hi[d] - lo[d]) * 0.125;
    return s;
  }
  static ParentSlopes limited(double p, const double* lo, const double* hi) {
    ParentSlopes s;
    s.value = p;
    for (int d = 0; d < D; ++d) s.slope[d] = 0.25 * minmod(hi[d] - p, p - lo[d]);
    return s;
  }
  double child(int child_number) const {
    double v = value;
    for (int d = 0; d < D; ++d) v += child_bit(child_number, d) ? slope[d] : -slope[d];
    return v;
  }
};

namespace detail {

// kQuadraticWeights<D>[child][code]: weight of the block value at code = sum_d (o_d+1) 3^d.
template <int D>
constexpr std::array<std::array<double, ipow(3, D)>, kChildren<D>> make_quadratic_weights() {
  std::array<std::array<double, ipow(3, D)>, kChildren<D>> w{};
  for (int b = 0; b < kChildren<D>; ++b)
    for (int code = 0; code < ipow(3, D); ++code) {
      double weight = 1.0;
      for (int d = 0, r = code; d < D; ++d, r /= 3) {
        const double xi = child_bit(b, d) ? 0.25 : -0.25;
        const int o = r % 3 - 1;
        weight *= o < 0 ? 0.5 * xi * (xi - 1.0) : (o == 0 ? 1.0 - xi * xi : 0.5 * xi * (xi + 1.0));
      }
      w[b][code] = weight;
    }
  return w;
}

}  // namespace detail

template <int D>
inline constexpr auto kQuadraticWeights = detail::make_quadratic_weights<D>();

// `block` holds the parent's 3^D neighbourhood indexed by code = sum_d (o_d + 1) 3^d.
template <int D>
double quadratic_child(const double* block, int child) {
  double v = 0.0;
  for (int code = 0; code < ipow(3, D); ++code) v += kQuadraticWeights<D>[child][code] * block[code];
  return v;
}

}  // namespace capsflow::tree
