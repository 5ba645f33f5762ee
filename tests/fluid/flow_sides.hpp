#pragma once
// Small helpers the flow tests share: pi and "every side of the brick is of one kind".
#include <array>
#include <cmath>

#include "fluid/flow_boundary.hpp"

namespace capsflow::fluid::testing {

inline const double kPi = std::acos(-1.0);

template <int D>
std::array<SideFlow<D>, 2 * D> all(SideKind k) {
  std::array<SideFlow<D>, 2 * D> s{};
  for (auto& x : s) x.kind = k;
  return s;
}

}  // namespace capsflow::fluid::testing
