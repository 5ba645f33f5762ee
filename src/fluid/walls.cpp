// Which boundaries are walls (why: walls.hpp).
#include "fluid/walls.hpp"

namespace capsflow::fluid {

bool is_wall(SideKind kind) {
  switch (kind) {  // no default: -Wswitch flags a new kind left undecided
    case SideKind::wall:
    case SideKind::moving_wall:
      return true;
    case SideKind::inflow:
    case SideKind::outflow:
    case SideKind::periodic:
    case SideKind::prescribed:
      return false;
  }
  return false;
}

template <int D>
bool touches_wall(const tree::TreeOptions<D>& tree, const std::array<SideFlow<D>, 2 * D>& sides,
                  const tree::Box<D>& b) {
  const double eps = 1e-9 * tree.root_size;
  for (int d = 0; d < D; ++d) {
    if (tree.periodic[d]) continue;
    const double lo = tree.origin[d], hi = lo + tree.roots[d] * tree.root_size;
    if (is_wall(sides[2 * d].kind) && b.lo[d] <= lo + eps) return true;
    if (is_wall(sides[2 * d + 1].kind) && b.hi[d] >= hi - eps) return true;
  }
  return false;
}

template bool touches_wall<2>(const tree::TreeOptions<2>&, const std::array<SideFlow<2>, 4>&,
                              const tree::Box<2>&);
template bool touches_wall<3>(const tree::TreeOptions<3>&, const std::array<SideFlow<3>, 6>&,
                              const tree::Box<3>&);

}  // namespace capsflow::fluid
