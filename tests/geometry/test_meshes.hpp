#pragma once
// Triangulated surfaces shared by the geometry tests.
#include <Eigen/Core>

#include "geometry/triangle_surface.hpp"

namespace capsflow::geometry::test {

// The box [lo, hi] as 12 triangles, counter-clockwise seen from outside.
inline TriangleMesh box_mesh(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  TriangleMesh m;
  m.vertices.resize(3, 8);
  for (int v = 0; v < 8; ++v)
    m.vertices.col(v) = Eigen::Vector3d((v & 1) ? hi[0] : lo[0], (v & 2) ? hi[1] : lo[1], (v & 4) ? hi[2] : lo[2]);
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6},    // z = lo, z = hi
                 {0, 1, 4}, {1, 5, 4}, {2, 6, 3}, {3, 6, 7},    // y = lo, y = hi
                 {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};   // x = lo, x = hi
  return m;
}

}  // namespace capsflow::geometry::test
