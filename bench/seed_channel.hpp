#pragma once
// The seed paper's channel as benchmark geometry: a 4 x 1 x 1 brick of side-2 roots
// (length 8, half-width 1), 6 levels (dx = 1/32 at the finest), refined to the finest
// level in a spherical shell of radius 0.85 (the capsule) of half-width 3 finest cells
// (the 4-cell IBM kernel plus a cell of motion).
#include <algorithm>
#include <cmath>

#include "tree/tree.hpp"

namespace capsflow::bench {

inline constexpr int kSeedMaxLevel = 6;
inline constexpr double kSeedRadius = 0.85;
inline constexpr double kSeedFine = 2.0 / (1 << kSeedMaxLevel);
inline constexpr double kSeedShellHalfWidth = 3 * kSeedFine;

inline tree::TreeOptions<3> seed_channel() {
  return {.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = kSeedMaxLevel};
}

// Required level of a box: the finest where it meets the shell centred at (centre_x, 0, 0).
inline auto seed_shell(double centre_x) {
  return [centre_x](const tree::Box<3>& b) {
    double near = 0.0, far = 0.0;
    for (int d = 0; d < 3; ++d) {
      const double c = d == 0 ? centre_x : 0.0;
      const double lo = b.lo[d] - c, hi = b.hi[d] - c;
      const double n = lo > 0 ? lo : (hi < 0 ? -hi : 0.0);
      const double f = std::max(std::abs(lo), std::abs(hi));
      near += n * n;
      far += f * f;
    }
    const bool meets = std::sqrt(near) <= kSeedRadius + kSeedShellHalfWidth &&
                       std::sqrt(far) >= kSeedRadius - kSeedShellHalfWidth;
    return meets ? kSeedMaxLevel : 0;
  };
}

}  // namespace capsflow::bench
