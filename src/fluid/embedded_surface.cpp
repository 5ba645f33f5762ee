// The walls' triangles on the tree (embedded_surface.hpp).
#include "fluid/embedded_surface.hpp"

#include "geometry/cut_cell.hpp"

namespace capsflow::fluid {

std::vector<double> wall_surface(const EmbeddedGeometry<3>& walls) {
  const tree::Tree<3>& t = walls.tree();
  std::vector<double> out;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<3>& lv = t.level(l);
    const double h = t.cell_size(l);
    for (const Index c : walls.cut_cells(l)) {
      if (!lv.is_leaf(c) || !t.owns(c)) continue;
      const tree::Point<3> centre = t.center(c);
      for (const auto& tri : geometry::wall_triangles(walls.corner_values(c, l)))
        for (int k = 0; k < 9; ++k) out.push_back(centre[k % 3] + (tri[static_cast<std::size_t>(k)] - 0.5) * h);
    }
  }
  return out;
}

}  // namespace capsflow::fluid
