#pragma once
// The elliptic operator's coefficients with embedded walls (issue "Walls of any shape"):
// the face coefficient alpha times the face's fluid fraction, and lambda times the cell's
// fluid fraction, so that L(a) is the balance of each cell's fluid part per unit of its whole
// volume (multigrid/wall_flux.hpp adds the walls' own flux). A cell without fluid has no
// open face and no wall: its lambda is set so that its equation reads a_c = -h^2 b_c (zero
// for the zero right-hand side it gets), and the solve never divides by a zero diagonal.
#include <span>
#include <vector>

#include "fluid/embedded_geometry.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

// 2D values per cell slot (coefficients.hpp's layout, every active cell of every level):
// alpha times the fluid fraction of each face.
template <int D>
void embedded_face_coefficients(const tree::Tree<D>& t, const EmbeddedGeometry<D>& g, double alpha,
                                std::vector<double>& out);

// One value per cell slot (every active cell): lambda times the cell's fluid fraction (and
// times scale[c] where scale is given: a density that varies), and -1/h^2 in cells without
// fluid (their equation a_c = -h^2 b_c: zero for b = 0).
template <int D>
void embedded_cell_coefficients(const tree::Tree<D>& t, const EmbeddedGeometry<D>& g, double lambda,
                                std::vector<double>& out, std::span<const double> scale = {});

extern template void embedded_face_coefficients<2>(const tree::Tree<2>&, const EmbeddedGeometry<2>&, double, std::vector<double>&);
extern template void embedded_face_coefficients<3>(const tree::Tree<3>&, const EmbeddedGeometry<3>&, double, std::vector<double>&);
extern template void embedded_cell_coefficients<2>(const tree::Tree<2>&, const EmbeddedGeometry<2>&, double, std::vector<double>&, std::span<const double>);
extern template void embedded_cell_coefficients<3>(const tree::Tree<3>&, const EmbeddedGeometry<3>&, double, std::vector<double>&, std::span<const double>);

}  // namespace capsflow::fluid
