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

}  // namespace capsflow::fluid::testing
