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

namespace detail {

// One direction of quadratic_children: in has directions < Dir reduced to the 2 child
// sides (index lo + n_lo (o + 3 hi)); res has Dir reduced too (lo + n_lo (side + 2 hi)).
// Constant bounds, so the loops unroll.
template <int D, int Dir>
void quadratic_pass(const double* in, double* res) {
  constexpr auto kWeight = [] {  // kWeight[side][o + 1], xi = -1/4 (side 0) or +1/4
    std::array<std::array<double, 3>, 2> w{};
    for (int side = 0; side < 2; ++side) {
      const double xi = side ? 0.25 : -0.25;
      w[side] = {0.5 * xi * (xi - 1.0), 1.0 - xi * xi, 0.5 * xi * (xi + 1.0)};
    }
    return w;
  }();
  constexpr int n_lo = 1 << Dir, n_hi = ipow(3, D - 1 - Dir);
  for (int hi = 0; hi < n_hi; ++hi)
    for (int side = 0; side < 2; ++side)
      for (int lo = 0; lo < n_lo; ++lo) {
        const double* v = in + lo + n_lo * 3 * hi;
        res[lo + n_lo * (side + 2 * hi)] =
            kWeight[side][0] * v[0] + kWeight[side][1] * v[n_lo] + kWeight[side][2] * v[2 * n_lo];
      }
}

}  // namespace detail

// All 2^D children at once (child b at out[b]), as quadratic_child gives them, by one 1D
// interpolation per direction (3^D -> 2 x 3^(D-1) -> ... -> 2^D values): 3 (3^D + ...
// + 2^D) multiplications instead of 2^D 3^D, which matters for a 3D halo group (114 vs 216).
template <int D>
void quadratic_children(const double* block, double* out) {
  static_assert(D == 2 || D == 3);
  double a[ipow(3, D)], b[ipow(3, D)];
  detail::quadratic_pass<D, 0>(block, a);
  if constexpr (D == 2) {
    detail::quadratic_pass<D, 1>(a, out);
  } else {
    detail::quadratic_pass<D, 1>(a, b);
    detail::quadratic_pass<D, 2>(b, out);
  }
}

}  // namespace capsflow::tree
