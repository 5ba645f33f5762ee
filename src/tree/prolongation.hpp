#pragma once
// Point kernels of the transfer between levels (pure functions, testable without a tree).
//
// A parent P of size H has children of size H/2 whose centres sit at x_P + s_d H/4 with
// s_d = -1 or +1 (child bit 0 or 1 along d). Second-order prolongation evaluates the
// linear reconstruction of P from its face neighbours at the child centre:
//   linear:  u_c = u_P + sum_d s_d (u_{P+e_d} - u_{P-e_d}) / 8        (central slope)
//   limited: u_c = u_P + sum_d s_d minmod(u_{P+e_d} - u_P, u_P - u_{P-e_d}) / 4
// Both are exact for linear fields and conserve the parent's mean (the s_d cancel in pairs).
// Restriction is the volume average of the 2^D children.
#include <cmath>

#include "tree/morton.hpp"

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

}  // namespace capsflow::tree
