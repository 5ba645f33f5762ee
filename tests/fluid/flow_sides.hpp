#pragma once
// Small helpers the flow tests share: pi, "every side of the brick is of one kind", and
// the observed order of a sequence of errors on grids refined by 2.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "fluid/flow_boundary.hpp"

namespace capsflow::fluid::testing {

inline const double kPi = std::acos(-1.0);

template <int D>
std::array<SideFlow<D>, 2 * D> all(SideKind k) {
  std::array<SideFlow<D>, 2 * D> s{};
  for (auto& x : s) x.kind = k;
  return s;
}

// Prints each observed order log2(e_coarse / e_fine) and asserts it is at least `least`.
inline void expect_orders_at_least(const char* what, const std::vector<double>& err, double least) {
  for (std::size_t i = 1; i < err.size(); ++i) {
    const double order = std::log2(err[i - 1] / err[i]);
    std::printf("%s max error %.3e -> %.3e, order %.2f\n", what, err[i - 1], err[i], order);
    EXPECT_GE(order, least) << what;
  }
}

// The least-squares slope of -log2(error) against the refinement step: the observed order
// over several grids, where one pair's order moves with where a wall or an interface falls
// in its cells.
inline double fitted_order(const std::vector<double>& errors) {
  const double n = static_cast<double>(errors.size());
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  for (std::size_t k = 0; k < errors.size(); ++k) {
    const double x = static_cast<double>(k), y = std::log2(errors[k]);
    sx += x;
    sy += y;
    sxx += x * x;
    sxy += x * y;
  }
  return -(n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace capsflow::fluid::testing
