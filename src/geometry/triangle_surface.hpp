#pragma once
// A closed triangulated surface (from STL, issue "Walls of any shape") as a solid: inside the
// surface is the solid. The surface is checked when it is made: every edge shared by exactly
// two triangles that run it in opposite directions (closed and consistently oriented), no
// degenerate triangle, the normals outwards (a positive enclosed volume). The signed distance
// is exact for the triangles: the nearest point through a bounding-box tree, the side from
// the angle-weighted pseudonormal of the nearest feature (face, edge or vertex; Baerentzen &
// Aanaes, IEEE TVCG 11(3), 2005), which gives the right side at every point of space.
#include <array>
#include <vector>

#include <Eigen/Core>

#include "geometry/solid.hpp"

namespace capsflow::geometry {

struct TriangleMesh {
  Eigen::Matrix3Xd vertices;
  std::vector<std::array<int, 3>> triangles;  // counter-clockwise seen from outside
};

// Throws std::invalid_argument naming the first defect (a bad index, a degenerate triangle,
// an open or non-manifold edge, an inconsistent orientation, inward normals).
[[nodiscard]] SolidPtr triangle_surface(TriangleMesh mesh);

}  // namespace capsflow::geometry
