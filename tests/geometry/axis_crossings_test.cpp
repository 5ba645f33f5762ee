// Grid lines crossing closed surfaces: on lines through a box mesh's vertices, along its edges
// and in its faces' planes, and on lines through an icosphere's nodes, every line crosses
// the surface an even number of times with the winding number back to 0, and the winding
// number at each point off the surface says on which side of the surface (the exact signed
// distance) the point lies.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "geometry/axis_crossings.hpp"
#include "geometry/triangle_surface.hpp"
#include "membrane/mesh.hpp"
#include "test_meshes.hpp"

namespace capsflow::geometry {
namespace {

using Eigen::Vector3d;
using test::box_mesh;

// Checks every line of a grid of spacing h over [-1, 1]^2 along each axis against the
// surface's signed distance at the points (i + 1/2) h along it; returns the lines with
// crossings.
int check_lines(const TriangleMesh& mesh, double h) {
  const SolidPtr solid = triangle_surface(mesh);
  const auto n = static_cast<long>(std::lround(1.0 / h));
  int crossed = 0;
  for (int a = 0; a < 3; ++a) {
    LineGrid g{.axis = a, .origin = {-1.0, -1.0}, .h = h, .lo = {0, 0}, .hi = {2 * n - 1, 2 * n - 1}};
    const AxisCrossings lines(mesh.vertices, mesh.triangles, g);
    for (long j = 0; j < 2 * n; ++j)
      for (long k = 0; k < 2 * n; ++k) {
        const auto line = lines.line(j, k);
        EXPECT_EQ(line.size() % 2, 0u) << "axis " << a << " line " << j << " " << k;
        EXPECT_TRUE(std::is_sorted(line.begin(), line.end(), [](const auto& x, const auto& y) { return x.s < y.s; }));
        EXPECT_EQ(lines.winding_below(j, k, 2.0), 0);
        crossed += line.empty() ? 0 : 1;
        for (long i = 0; i < 2 * n; ++i) {
          Vector3d p;
          p[a] = -1.0 + (static_cast<double>(i) + 0.5) * h;
          p[(a + 1) % 3] = -1.0 + (static_cast<double>(j) + 0.5) * h;
          p[(a + 2) % 3] = -1.0 + (static_cast<double>(k) + 0.5) * h;
          const double d = solid->signed_distance(p);
          if (std::abs(d) < 1e-12) continue;  // on the surface: either side
          const int w = lines.winding_below(j, k, p[a]);
          if (w != (d < 0 ? 1 : 0)) {
            ADD_FAILURE() << "winding " << w << " along axis " << a << " at " << p.transpose() << ", distance " << d;
            return crossed;
          }
        }
      }
  }
  return crossed;
}

TEST(AxisCrossings, LinesThroughABoxsVerticesEdgesAndFacesCountOnce) {
  // h = 1/8: the box's faces lie on the lines' coordinates, so lines run along its edges,
  // through its vertices and inside its faces' planes.
  EXPECT_GT(check_lines(box_mesh(Vector3d(-0.4375, -0.3125, -0.5625), Vector3d(0.5625, 0.4375, 0.3125)), 0.125), 0);
}

TEST(AxisCrossings, LinesThroughAnIcospheresNodesCountOnce) {
  // Node 0 of the icosphere moved onto a line's point, and the sphere shifted so that
  // many nodes sit on the planes of the grid's lines.
  membrane::Mesh m = membrane::make_icosphere({.order = membrane::Order::p1, .level = 3, .radius = 0.7});
  TriangleMesh mesh;
  mesh.vertices = m.nodes;
  mesh.triangles = membrane::flat_triangles(m);
  const double h = 1.0 / 16;
  mesh.vertices.colwise() += Vector3d(0.5 * h, 0.5 * h, 0.5 * h) - mesh.vertices.col(0);
  for (Eigen::Index v = 0; v < mesh.vertices.cols(); v += 3)  // a third of the nodes on line planes
    mesh.vertices(1, v) = std::round(mesh.vertices(1, v) / h - 0.5) * h + 0.5 * h;
  EXPECT_GT(check_lines(mesh, h), 0);
}

TEST(AxisCrossings, NormalsAreUnitComponentsSignedByTheCrossingsDirection) {
  const TriangleMesh box = box_mesh(Vector3d(-0.3, -0.3, -0.3), Vector3d(0.3, 0.3, 0.3));
  const AxisCrossings lines(box.vertices, box.triangles, {.axis = 2, .origin = {-1.0, -1.0}, .h = 0.25, .lo = {0, 0}, .hi = {7, 7}});
  const auto line = lines.line(3, 4);  // x = -0.125, y = 0.125
  ASSERT_EQ(line.size(), 2u);
  EXPECT_DOUBLE_EQ(line[0].s, -0.3);
  EXPECT_DOUBLE_EQ(line[0].normal, -1.0);
  EXPECT_DOUBLE_EQ(line[1].s, 0.3);
  EXPECT_DOUBLE_EQ(line[1].normal, 1.0);
  EXPECT_TRUE(lines.line(8, 0).empty());  // outside the grid's lines
}

}  // namespace
}  // namespace capsflow::geometry
