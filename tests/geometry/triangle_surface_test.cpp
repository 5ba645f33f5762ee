// Closed triangulated surfaces as solids: a 12-triangle box gives geometry::box's exact
// distances; an icosphere and an ellipsoid mesh agree with their analytic solids to within
// the faceting error, keep the closest-point property and are 1-Lipschitz; every defect of a
// surface is refused with its own message.
#include <gtest/gtest.h>
#include <gmock/gmock.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "geometry/solid.hpp"
#include "geometry/triangle_surface.hpp"
#include "test_meshes.hpp"
#include "membrane/mesh.hpp"

namespace capsflow::geometry {
namespace {

using Eigen::Vector3d;
using test::box_mesh;

TriangleMesh from_membrane(const membrane::Mesh& mesh) {
  TriangleMesh m;
  m.vertices = mesh.nodes;
  for (std::int64_t e = 0; e < mesh.element_count(); ++e) {
    const auto el = mesh.element(e);
    m.triangles.push_back({el[0], el[1], el[2]});
  }
  return m;
}

Vector3d random_point(std::mt19937_64& rng, double half) {
  std::uniform_real_distribution<double> u(-half, half);
  return {u(rng), u(rng), u(rng)};
}

TEST(TriangleSurface, ABoxMeshIsTheBox) {
  const Vector3d lo(-1, -0.5, 0.25), hi(1.5, 0.5, 2);
  const SolidPtr mesh = triangle_surface(box_mesh(lo, hi));
  const SolidPtr exact = box(lo, hi);
  std::mt19937_64 rng(1);
  for (int i = 0; i < 4000; ++i) {
    const Vector3d x = random_point(rng, 3.0);
    EXPECT_NEAR(mesh->signed_distance(x), exact->signed_distance(x), 1e-12) << x.transpose();
  }
  // Along the diagonals through the corners and edges, where the sign comes from vertex and
  // edge pseudonormals.
  for (const double t : {0.01, 0.3, 2.0}) {
    EXPECT_NEAR(mesh->signed_distance(hi + t * Vector3d(1, 1, 1)), t * std::sqrt(3.0), 1e-12);
    EXPECT_NEAR(mesh->signed_distance(lo + t * Vector3d(-1, -1, 0)), t * std::sqrt(2.0), 1e-12);
  }
}

TEST(TriangleSurface, FacetedSphereAndEllipsoidFollowTheirSolids) {
  std::mt19937_64 rng(2);
  for (const int level : {3, 4}) {
    const membrane::Mesh ico = membrane::make_icosphere({.level = level, .radius = 1.0});
    // The faceting error: the vertices lie on the sphere, so the farthest a triangle gets
    // from it is 1 minus its plane's distance from the centre.
    double gap = 0.0;
    for (std::int64_t e = 0; e < ico.element_count(); ++e) {
      const auto el = ico.element(e);
      const Vector3d a = ico.nodes.col(el[0]), b = ico.nodes.col(el[1]), c = ico.nodes.col(el[2]);
      gap = std::max(gap, 1.0 - std::abs((b - a).cross(c - a).normalized().dot(a)));
    }
    const SolidPtr mesh = triangle_surface(from_membrane(ico));
    const SolidPtr ball = sphere(Vector3d::Zero(), 1.0);
    for (int i = 0; i < 2000; ++i) {
      const Vector3d x = random_point(rng, 2.0);
      EXPECT_NEAR(mesh->signed_distance(x), ball->signed_distance(x), gap + 1e-12) << x.transpose();
      // 1-Lipschitz.
      const Vector3d y = x + random_point(rng, 0.3);
      EXPECT_LE(std::abs(mesh->signed_distance(x) - mesh->signed_distance(y)), (x - y).norm() * (1 + 1e-12));
    }
  }
  // An ellipsoid (a stretched icosphere): points well inside or outside are classified as
  // the analytic ellipsoid classifies them.
  TriangleMesh ellipsoid = from_membrane(membrane::make_icosphere({.level = 4, .radius = 1.0}));
  const Vector3d axes(1.6, 0.7, 0.5);
  ellipsoid.vertices = axes.asDiagonal() * ellipsoid.vertices;
  const SolidPtr mesh = triangle_surface(ellipsoid);
  int classified = 0;
  for (int i = 0; i < 4000; ++i) {
    const Vector3d x = random_point(rng, 2.0);
    const double level = x.cwiseQuotient(axes).squaredNorm();
    if (std::abs(level - 1.0) < 0.1) continue;  // within the faceting error of the surface
    EXPECT_EQ(mesh->signed_distance(x) < 0, level < 1.0) << x.transpose();
    ++classified;
  }
  EXPECT_GT(classified, 3000);
}

// The winding number of a closed surface about x (the solid angles of its triangles over
// 4 pi; Van Oosterom & Strackee, IEEE TBME 30(2), 1983): 1 inside, 0 outside, by a route
// that does not use the nearest point.
double winding_number(const TriangleMesh& m, const Vector3d& x) {
  double sum = 0.0;
  for (const auto& t : m.triangles) {
    const Vector3d a = m.vertices.col(t[0]) - x, b = m.vertices.col(t[1]) - x, c = m.vertices.col(t[2]) - x;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    sum += 2.0 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
  }
  return sum / (4.0 * 3.14159265358979323846);
}

TEST(TriangleSurface, TheSideOfEveryPointOfANonConvexSurfaceIsItsWindingNumbers) {
  // A bumpy sphere: the radius of each vertex of an icosphere changed by 35% along a few
  // lobes, so the surface has saddles and dents where the nearest point is often an edge or
  // a vertex whose neighbours face away from each other.
  TriangleMesh m = from_membrane(membrane::make_icosphere({.level = 3, .radius = 1.0}));
  for (Eigen::Index v = 0; v < m.vertices.cols(); ++v) {
    const Vector3d u = m.vertices.col(v);
    m.vertices.col(v) = u * (1.0 + 0.35 * std::sin(3.0 * std::atan2(u[1], u[0])) * (1.0 - u[2] * u[2]));
  }
  const SolidPtr s = triangle_surface(m);
  std::mt19937_64 rng(3);
  int inside = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vector3d x = random_point(rng, 1.6);
    const double w = winding_number(m, x);
    ASSERT_NEAR(w, std::round(w), 1e-6) << "a closed surface";
    const double phi = s->signed_distance(x);
    if (std::abs(phi) < 1e-9) continue;
    EXPECT_EQ(phi < 0, std::round(w) == 1.0) << x.transpose() << " phi " << phi;
    inside += phi < 0;
  }
  EXPECT_GT(inside, 300);
}

// The tip of a needle: its three side faces' normals point well apart, so a point in the
// tip's normal cone can lie behind one of the faces that meet there. The side of such a
// point needs the vertex's pseudonormal; a face's normal would get it wrong.
TEST(TriangleSurface, PointsAroundANeedleTipAreOutside) {
  TriangleMesh m;
  m.vertices.resize(3, 4);
  for (int k = 0; k < 3; ++k) {
    const double a = 2.0 * 3.14159265358979323846 * k / 3.0;
    m.vertices.col(k) = Vector3d(0.1 * std::cos(a), 0.1 * std::sin(a), 0.0);
  }
  const Vector3d tip(0, 0, 2);
  m.vertices.col(3) = tip;
  m.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
  const SolidPtr needle = triangle_surface(m);
  std::vector<Vector3d> normals;
  for (std::size_t t = 1; t < 4; ++t) {
    const auto& tri = m.triangles[t];
    normals.push_back((m.vertices.col(tri[1]) - m.vertices.col(tri[0])).cross(m.vertices.col(tri[2]) - m.vertices.col(tri[0])).normalized());
  }
  for (int i = 0; i < 3; ++i) {
    // Inside the tip's normal cone, far on the side opposite face i.
    const Vector3d d = normals[static_cast<std::size_t>((i + 1) % 3)] + normals[static_cast<std::size_t>((i + 2) % 3)] +
                       0.1 * normals[static_cast<std::size_t>(i)];
    ASSERT_LT(d.dot(normals[static_cast<std::size_t>(i)]), 0.0) << "the point lies behind face " << i;
    const Vector3d x = tip + 0.3 * d.normalized();
    EXPECT_NEAR(needle->signed_distance(x), 0.3, 1e-12) << "around face " << i;
  }
}

TEST(TriangleSurface, EveryDefectIsRefusedWithItsOwnMessage) {
  auto message = [](TriangleMesh m) {
    try {
      (void)triangle_surface(std::move(m));
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const TriangleMesh good = box_mesh({0, 0, 0}, {1, 1, 1});
  EXPECT_EQ(message(good), "accepted");
  TriangleMesh open = good;
  open.triangles.pop_back();
  EXPECT_THAT(message(open), testing::HasSubstr("not closed"));
  TriangleMesh flipped_one = good;
  std::swap(flipped_one.triangles[3][0], flipped_one.triangles[3][1]);
  EXPECT_THAT(message(flipped_one), testing::HasSubstr("inconsistent orientation"));
  TriangleMesh inward = good;
  for (auto& t : inward.triangles) std::swap(t[0], t[1]);
  EXPECT_THAT(message(inward), testing::HasSubstr("normals point inwards"));
  TriangleMesh bad_index = good;
  bad_index.triangles[0][2] = 8;
  EXPECT_THAT(message(bad_index), testing::HasSubstr("names vertex 8 of 8"));
  TriangleMesh degenerate = good;
  degenerate.vertices.col(3) = degenerate.vertices.col(1);
  EXPECT_THAT(message(degenerate), testing::HasSubstr("degenerate"));
  EXPECT_THAT(message({}), testing::HasSubstr("no triangles"));
}

}  // namespace
}  // namespace capsflow::geometry
