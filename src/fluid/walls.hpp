#pragma once
// Walls: the boundaries where the flow sticks (no slip), so that boundary layers form there
// and adapt.wall_level refines them: the brick's sides of kind wall and moving_wall
// (inflow, outflow, prescribed and periodic sides are not walls: the flow crosses them),
// and the embedded walls of solids inside the brick (fluid/embedded_geometry.hpp), so that
// everything asking "is this a wall" has one answer.
#include <array>

#include "fluid/embedded_geometry.hpp"
#include "fluid/flow_boundary.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

// Whether a side of this kind is a wall (no slip).
[[nodiscard]] bool is_wall(SideKind kind);

// Whether the leaf box b touches a wall side of the brick (within 1e-9 root sizes).
template <int D>
[[nodiscard]] bool touches_wall(const tree::TreeOptions<D>& tree, const std::array<SideFlow<D>, 2 * D>& sides,
                                const tree::Box<D>& b);

// The same, or the box may reach an embedded wall (`embedded` may be null: none). A brick's
// side buried in a solid is no wall of the flow: a box there that is surely all solid does
// not touch a wall (the seed channel as an embedded box in a larger brick refined the solid
// along the brick's sides: 1.8x the cells).
template <int D>
[[nodiscard]] bool touches_wall(const tree::TreeOptions<D>& tree, const std::array<SideFlow<D>, 2 * D>& sides,
                                const EmbeddedGeometry<D>* embedded, const tree::Box<D>& b) {
  if (!embedded) return touches_wall<D>(tree, sides, b);
  if (embedded->near_wall(b, 0.0)) return true;
  return touches_wall<D>(tree, sides, b) && !embedded->surely_solid(b);
}

extern template bool touches_wall<2>(const tree::TreeOptions<2>&, const std::array<SideFlow<2>, 4>&,
                                     const tree::Box<2>&);
extern template bool touches_wall<3>(const tree::TreeOptions<3>&, const std::array<SideFlow<3>, 6>&,
                                     const tree::Box<3>&);

}  // namespace capsflow::fluid
