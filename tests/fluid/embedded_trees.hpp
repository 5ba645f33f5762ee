#pragma once
// Trees for the embedded-wall tests: refined to `fine` within `band` finest cells of a
// solid's wall (a box within the band when its centre's |phi| is at most its half diagonal
// plus the band), `coarse` elsewhere.
#include <cmath>

#include <Eigen/Core>

#include "geometry/solid.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid::testing {

template <int D>
tree::Tree<D> refined_along(const geometry::SolidPtr& solid, int coarse, int fine, double band) {
  tree::TreeOptions<D> o;
  o.roots.fill(1);
  o.max_level = fine;
  tree::Tree<D> t(o);
  t.refine_to([&](const tree::Box<D>& b) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    double half = 0.0;
    for (int d = 0; d < D; ++d) {
      centre[d] = 0.5 * (b.lo[d] + b.hi[d]);
      half += 0.25 * (b.hi[d] - b.lo[d]) * (b.hi[d] - b.lo[d]);
    }
    const double reach = std::sqrt(half) + band * std::pow(2.0, -fine);
    return std::abs(solid->signed_distance(centre)) <= reach ? fine : coarse;
  });
  return t;
}

}  // namespace capsflow::fluid::testing
