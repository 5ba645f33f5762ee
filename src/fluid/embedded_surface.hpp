#pragma once
// The embedded walls as a surface for ParaView (issue "Walls of any shape": the solid shown as
// its fraction and as its wall): the triangles of each cut leaf's wall (geometry::wall_triangles,
// the wall the operators measure, at each leaf's own resolution), in absolute coordinates,
// oriented out of the solid.
#include <vector>

#include "fluid/embedded_geometry.hpp"

namespace capsflow::fluid {

// 9 numbers per triangle (its three vertices), over the cut leaves this rank owns, level by
// level in index order.
[[nodiscard]] std::vector<double> wall_surface(const EmbeddedGeometry<3>& walls);

}  // namespace capsflow::fluid
