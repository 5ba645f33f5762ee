#pragma once
// Trees for the embedded-wall tests: refined by a rule on each box's centre and half
// diagonal (refined_by), and the common one, refined to `fine` within `band` finest cells of
// a solid's wall (a box within the band when its centre's |phi| is at most its half diagonal
// plus the band), `coarse` elsewhere (refined_along).
#include <cmath>
#include <functional>

#include <Eigen/Core>

#include "geometry/solid.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid::testing {

// One root per direction, levels up to max_level; `level(centre, half_diagonal)` is each
// box's required level (the centre's unused coordinates are 0 in 2D).
template <int D>
tree::Tree<D> refined_by(int max_level, const std::function<int(const Eigen::Vector3d&, double)>& level) {
  tree::TreeOptions<D> o;
  o.roots.fill(1);
  o.max_level = max_level;
  tree::Tree<D> t(o);
  t.refine_to([&](const tree::Box<D>& b) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    double half = 0.0;
    for (int d = 0; d < D; ++d) {
      centre[d] = 0.5 * (b.lo[d] + b.hi[d]);
      half += 0.25 * (b.hi[d] - b.lo[d]) * (b.hi[d] - b.lo[d]);
    }
    return level(centre, std::sqrt(half));
  });
  return t;
}

template <int D>
tree::Tree<D> refined_along(const geometry::SolidPtr& solid, int coarse, int fine, double band) {
  return refined_by<D>(fine, [&](const Eigen::Vector3d& centre, double half) {
    const double reach = half + band * std::pow(2.0, -fine);
    return std::abs(solid->signed_distance(centre)) <= reach ? fine : coarse;
  });
}

}  // namespace capsflow::fluid::testing
