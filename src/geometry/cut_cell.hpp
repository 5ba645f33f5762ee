#pragma once
// A cell cut by a wall (issue "Walls of any shape"): its fluid volume, the fluid part of each
// face and the wall inside it, from the signed distance phi at its 2^D corners (phi > 0 is
// fluid). phi is taken linear on each simplex of the cell's Freudenthal (Kuhn) triangulation,
// the D! simplices {x_p1 >= x_p2 >= ...} for each permutation p, whose faces on a cell face
// split it along the diagonal from its lowest to its highest corner. That triangulation is
// the same on both sides of every face of a uniform grid, so two cells sharing a face compute
// the same face fraction, and for one cell everything comes from one piecewise-linear wall:
//   - a plane wall is reproduced exactly (volume, faces, wall area, normal, centroid);
//   - the discrete divergence theorem holds to rounding: the wall's area vector (integral of
//     the normal out of the fluid) is minus the sum of the faces' fluid areas times their
//     outward normals, wall[d] = face[2d] - face[2d + 1] in units of h^(D-1);
//   - the wall is placed to second order in h for a smooth phi (linear interpolation along
//     the edges), as Basilisk's embed.h and AMReX's EB2 place theirs.
// The embedded-boundary operators read these numbers; the tree-wide assembly is
// fluid/embedded_geometry.
#include <array>
#include <vector>

namespace capsflow::geometry {

template <int D>
struct CellCut {
  static constexpr int kCorners = 1 << D;
  double volume = 1.0;                      // fluid volume / cell volume, in [0, 1]
  std::array<double, 2 * D> face{};         // fluid area / face area; face k = 2d + side (0 low, 1 high)
  std::array<double, D> wall{};             // integral of n over the wall / h^(D-1), n into the solid
  double wall_area = 0.0;                   // wall area / h^(D-1)
  std::array<double, D> wall_centroid{};    // from the cell's lower corner, in units of h (wall_area > 0)
  bool cut() const { return wall_area > 0.0; }
};

// The cut of the unit cell whose corner b (coordinate d = bit d of b) has the value phi[b].
// Corners with phi > 0 are fluid, phi <= 0 solid: a wall through corners then belongs to the
// fluid cells that touch it (a wall on a face closes that face and is the fluid cell's own
// wall; the cell beyond is empty), so a face with an open part always has fluid on both sides.
template <int D>
[[nodiscard]] CellCut<D> cut_cell(const std::array<double, (1 << D)>& phi);

// The fluid fraction of the face of the unit cell across which coordinate d is constant,
// from its 2^(D-1) corner values in the order of the remaining coordinates' bits (lowest
// remaining axis first): what cut_cell gives for that face, for a caller that has one face.
template <int D>
[[nodiscard]] double face_fraction(const std::array<double, (1 << (D - 1))>& phi);

// The wall of the unit cell with corner values phi (3D): the triangles of its piecewise-linear
// zero set on the Freudenthal simplices, the wall whose area and area vector cut_cell gives,
// each triangle (x0, x1, x2) in cell coordinates, 9 numbers, oriented so that
// (x1 - x0) x (x2 - x0) points out of the solid. None for a cell wholly on one side. For
// ParaView (the wall as a surface).
[[nodiscard]] std::vector<std::array<double, 9>> wall_triangles(const std::array<double, 8>& phi);

extern template CellCut<2> cut_cell<2>(const std::array<double, 4>&);
extern template CellCut<3> cut_cell<3>(const std::array<double, 8>&);
extern template double face_fraction<2>(const std::array<double, 2>&);
extern template double face_fraction<3>(const std::array<double, 4>&);

}  // namespace capsflow::geometry
