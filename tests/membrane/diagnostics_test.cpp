// Shape diagnostics: area and volume convergence on the sphere (asserted orders), exact
// identities of the discrete volume integrals, the Taylor parameters of the seed ellipsoid.
#include "membrane/diagnostics.hpp"
#include "membrane/mesh.hpp"
#include "membrane/shapes.hpp"
#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

namespace capsflow::membrane {
namespace {

constexpr double pi = std::numbers::pi;
constexpr double a = 0.85;

struct Convergence {
  Order order;
  std::vector<int> levels;
  double min_order;
};

// Relative errors of area and volume of the discrete sphere, and their observed orders
// (the mesh size halves from one level to the next).
void check_sphere_convergence(const Convergence& c) {
  double previous_area = 0.0, previous_volume = 0.0;
  for (const int level : c.levels) {
    const Mesh mesh = make_icosphere({.order = c.order, .level = level, .radius = a, .centre = {0.2, 0.1, -3.0}});
    const ShapeDiagnostics d = shape_diagnostics(mesh, mesh.nodes);
    const double area_error = std::abs(d.area - 4 * pi * a * a) / (4 * pi * a * a);
    const double volume_error = std::abs(d.volume - 4 * pi * a * a * a / 3) / (4 * pi * a * a * a / 3);
    std::printf("[ sphere    ] %s nodes %6lld  area error %.3e  volume error %.3e", c.order == Order::p1 ? "P1" : "P2",
                static_cast<long long>(mesh.node_count()), area_error, volume_error);
    if (previous_area > 0.0) {
      const double area_order = test::observed_order(previous_area, area_error);
      const double volume_order = test::observed_order(previous_volume, volume_error);
      std::printf("  orders %.2f %.2f", area_order, volume_order);
      EXPECT_GT(area_order, c.min_order) << "level " << level;
      EXPECT_GT(volume_order, c.min_order) << "level " << level;
    }
    std::printf("\n");
    previous_area = area_error;
    previous_volume = volume_error;
  }
}

TEST(membrane_diagnostics, P1SphereAreaAndVolumeConvergeAtSecondOrder) {
  check_sphere_convergence({.order = Order::p1, .levels = {2, 3, 4, 5, 6}, .min_order = 1.95});
}

TEST(membrane_diagnostics, P2SphereAreaAndVolumeConvergeAtFourthOrder) {
  check_sphere_convergence({.order = Order::p2, .levels = {3, 4, 5, 6}, .min_order = 3.9});
}

// Two independent evaluations of the same polyhedron: P1 in closed form (tetrahedra), and
// P2 by the degree-8 quadrature on a P2 mesh whose mid-edge nodes sit at the chord midpoints
// (flat elements). Exact integration makes them agree to round-off.
TEST(membrane_diagnostics, P1ClosedFormAndP2QuadratureAgreeOnFlatElements) {
  for (const int level : {3, 5}) {
    const Mesh p1 = make_icosphere({.order = Order::p1, .level = level - 1, .radius = a});
    Mesh p2 = make_icosphere({.order = Order::p2, .level = level, .radius = a});
    ASSERT_EQ(p1.elements.size() * 2, p2.elements.size());
    for (std::int64_t e = 0; e < p2.element_count(); ++e) {
      const auto v = p2.element(e);
      for (int k = 0; k < 3; ++k) {
        ASSERT_EQ(v[k], p1.element(e)[k]);  // same vertices, same element order
        p2.nodes.col(v[3 + k]) = 0.5 * (p2.nodes.col(v[k]) + p2.nodes.col(v[(k + 1) % 3]));
      }
    }
    const Eigen::Vector3d centre(0.3, 0.0, -1.0);
    const Eigen::Matrix3Xd x1 = seed_ellipsoid(p1.nodes.colwise() + centre, centre);
    const Eigen::Matrix3Xd x2 = seed_ellipsoid(p2.nodes.colwise() + centre, centre);
    const ShapeDiagnostics d1 = shape_diagnostics(p1, x1), d2 = shape_diagnostics(p2, x2);
    EXPECT_NEAR(d2.area, d1.area, 1e-14 * d1.area);
    EXPECT_NEAR(d2.volume, d1.volume, 1e-14 * d1.volume);
    EXPECT_LT((d2.centroid - d1.centroid).norm(), 1e-14);
    EXPECT_LT((d2.inertia - d1.inertia).norm(), 1e-14 * d1.inertia.norm());
  }
}

TEST(membrane_diagnostics, VolumeIntegralsAreInvariantUnderRigidMotions) {
  std::mt19937 rng(1);
  // P2 (curved): exact integration makes volume and second moments invariant under rigid
  // motions (a quadrature error would leave terms in the translation and rotation).
  for (const Order order : {Order::p1, Order::p2}) {
    const Mesh mesh = make_icosphere({.order = order, .level = 3});
    const Eigen::Matrix3Xd x = seed_ellipsoid(mesh.nodes, Eigen::Vector3d::Zero());
    const Eigen::Matrix3d r = test::random_rotation(rng);
    const Eigen::Vector3d t(4.0, -0.7, 0.3);
    const ShapeDiagnostics d = shape_diagnostics(mesh, x);
    const ShapeDiagnostics moved = shape_diagnostics(mesh, (r * x).colwise() + t);
    EXPECT_NEAR(moved.volume, d.volume, 1e-14 * d.volume);
    EXPECT_NEAR(moved.area, d.area, 1e-14 * d.area);
    EXPECT_LT((moved.centroid - (r * d.centroid + t)).norm(), 1e-14 * t.norm());
    EXPECT_LT((moved.inertia - r * d.inertia * r.transpose()).norm(), 1e-13 * d.inertia.norm());
    EXPECT_LT(d.centroid.norm(), 1e-15);  // the icosphere is centrally symmetric
  }
}

// The icosphere keeps the icosahedron's rotation group, under which the only invariant
// symmetric tensors are multiples of the identity: the discrete sphere's inertia tensor is
// isotropic and its D12 zero to round-off, at every resolution. The cyclic symmetry
// x -> y -> z of the icosahedron's coordinates makes the bounding box a cube: D12_bbox = 0.
TEST(membrane_diagnostics, SphereTaylorParametersVanish) {
  for (const Order order : {Order::p1, Order::p2})
    for (const int level : {3, 5}) {
      const Mesh mesh = make_icosphere({.order = order, .level = level, .radius = a, .centre = {1.0, 0.0, 0.5}});
      const ShapeDiagnostics d = shape_diagnostics(mesh, mesh.nodes);
      EXPECT_LT(d.d12, 1e-13);
      EXPECT_LT(std::abs(d.d12_bbox), 1e-15);
      const double i0 = d.inertia.trace() / 3;
      EXPECT_LT((d.inertia - i0 * Eigen::Matrix3d::Identity()).norm(), 1e-13 * i0);
      EXPECT_LT((d.centroid - Eigen::Vector3d(1.0, 0.0, 0.5)).norm(), 1e-14);
    }
}

// The seed ellipsoid is the linear image A X of the discrete sphere, A = diag(2, 1/sqrt2,
// 1/sqrt2): its second-moment tensor is det(A) A J_sphere A^T with J_sphere isotropic (see
// above), so its inertia-ellipsoid axes are exactly proportional to (2, 1/sqrt2, 1/sqrt2) and
// D12 equals (2 - 1/sqrt2)/(2 + 1/sqrt2) to round-off, not just within the discretisation
// error; the icosphere has nodes on the coordinate axes, so D12_bbox and the extent (the
// axes' full lengths, the lengths a capsule in a channel is measured by) are exact too. The axes'
// lengths, the area and the inertia converge to the ellipsoid's (orders asserted).
TEST(membrane_diagnostics, SeedEllipsoidTaylorParameters) {
  const double big = 2 * a, small = a / std::sqrt(2.0);
  const double d12_exact = (big - small) / (big + small);
  const double e = std::sqrt(1 - small * small / (big * big));
  const double area_exact = 2 * pi * small * small * (1 + big / (small * e) * std::asin(e));
  const double volume_exact = 4 * pi * big * small * small / 3;
  std::mt19937 rng(4);
  for (const auto& [order, levels, min_order] :
       {std::tuple{Order::p1, std::vector<int>{3, 4, 5}, 1.9}, std::tuple{Order::p2, std::vector<int>{3, 4, 5}, 3.5}}) {
    double previous[3] = {0, 0, 0};
    for (const int level : levels) {
      const Mesh mesh = make_icosphere({.order = order, .level = level, .radius = a});
      const Eigen::Vector3d centre(0.5, -0.25, 0.0);
      const ShapeDiagnostics sphere = shape_diagnostics(mesh, mesh.nodes);
      const ShapeDiagnostics d = shape_diagnostics(mesh, seed_ellipsoid(mesh.nodes.colwise() + centre, centre));
      EXPECT_NEAR(d.d12, d12_exact, 1e-13);
      EXPECT_NEAR(d.d12_bbox, d12_exact, 1e-14);
      EXPECT_LT((d.extent - Eigen::Vector3d(2 * big, 2 * small, 2 * small)).norm(), 1e-14);
      EXPECT_NEAR(d.volume, sphere.volume, 1e-14 * sphere.volume);  // det A = 1
      EXPECT_LT((d.centroid - centre).norm(), 1e-14);
      EXPECT_NEAR(std::abs(d.axes(0, 0)), 1.0, 1e-12);  // the major axis is Ox
      // A rotated ellipsoid has the same D12 and a rotated major axis.
      const Eigen::Matrix3d r = test::random_rotation(rng);
      const ShapeDiagnostics rotated = shape_diagnostics(mesh, r * seed_ellipsoid(mesh.nodes, Eigen::Vector3d::Zero()));
      EXPECT_NEAR(rotated.d12, d12_exact, 1e-13);
      EXPECT_NEAR(std::abs(rotated.axes.col(0).dot(r.col(0))), 1.0, 1e-12);
      const double errors[3] = {std::abs(d.area - area_exact) / area_exact, std::abs(d.volume - volume_exact) / volume_exact,
                                std::abs(d.semi_axes[0] - big) / big};
      std::printf("[ ellipsoid ] %s nodes %6lld  D12 %.15f (exact %.15f)  D12_bbox %.15f  area error %.3e  volume error %.3e  "
                  "axis error %.3e\n",
                  order == Order::p1 ? "P1" : "P2", static_cast<long long>(mesh.node_count()), d.d12, d12_exact, d.d12_bbox,
                  errors[0], errors[1], errors[2]);
      for (int k = 0; k < 3; ++k) {
        if (previous[k] > 0.0) {
          EXPECT_GT(test::observed_order(previous[k], errors[k]), min_order) << "quantity " << k;
        }
        previous[k] = errors[k];
      }
      EXPECT_NEAR(d.semi_axes[1], d.semi_axes[2], 1e-12);
      EXPECT_NEAR(d.semi_axes[1] / d.semi_axes[0], small / big, 1e-13);
    }
  }
}

// The seed ellipsoid turned by theta about z has its inclination theta / pi (an axis: theta
// and theta + pi are one, so 0.7 pi reads -0.3). Keller & Skalak's tank-treading field on
// it, u = w (-(a/b) y, (b/a) x, 0) in its own axes, plus any translation, has the phase rate
// w exactly (the shape stays: u is tangent to the ellipsoid), and so has a sphere's rigid
// rotation at rate w.
TEST(membrane_diagnostics, InclinationAndTankTreadingRateInTheShearPlane) {
  const Mesh mesh = make_icosphere({.order = Order::p2, .level = 3, .radius = a});
  const Eigen::Matrix3Xd body = seed_ellipsoid(mesh.nodes, Eigen::Vector3d::Zero());  // semi-axes 2a, a/sqrt2, a/sqrt2
  const double big = 2 * a, small = a / std::sqrt(2.0), w = 0.7;
  for (const double theta : {0.0, 0.1, 0.25, 0.4, 0.7, -0.2}) {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(theta * pi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Matrix3Xd x = (r * body).colwise() + Eigen::Vector3d(0.3, -0.2, 0.1);
    Eigen::Matrix3Xd v(3, x.cols());
    for (Eigen::Index i = 0; i < x.cols(); ++i)
      v.col(i) = r * Eigen::Vector3d(-w * big / small * body(1, i), w * small / big * body(0, i), 0.0) +
                 Eigen::Vector3d(1.0, 2.0, 3.0);
    const ShapeDiagnostics d = shape_diagnostics(mesh, x);
    EXPECT_NEAR(inclination_xy(d), theta > 0.5 ? theta - 1.0 : theta, 1e-12) << theta;
    EXPECT_NEAR(tank_treading_rate(d, x, v), w, 1e-12) << theta;
  }
  const Eigen::Matrix3Xd sphere = mesh.nodes.colwise() + Eigen::Vector3d(0.5, 0.5, 0.5);
  Eigen::Matrix3Xd v(3, sphere.cols());
  for (Eigen::Index i = 0; i < sphere.cols(); ++i) v.col(i) = Eigen::Vector3d(-w * mesh.nodes(1, i), w * mesh.nodes(0, i), 0.0);
  EXPECT_NEAR(tank_treading_rate(shape_diagnostics(mesh, sphere), sphere, v), w, 1e-12);
}

TEST(membrane_diagnostics, MaxNodeDistance) {
  const Mesh mesh = make_icosphere({.order = Order::p1, .level = 3});
  const Eigen::Vector3d shift(0.3, -0.4, 1.2);
  EXPECT_NEAR(max_node_distance(mesh.nodes, mesh.nodes.colwise() + shift), shift.norm(), 1e-15);
  Eigen::Matrix3Xd y = mesh.nodes;
  y.col(100) += Eigen::Vector3d(0.0, 0.0, 0.25);
  y.col(200) += Eigen::Vector3d(0.1, 0.0, 0.0);
  EXPECT_EQ(max_node_distance(mesh.nodes, y), 0.25);
  EXPECT_EQ(max_node_distance(mesh.nodes, mesh.nodes), 0.0);
  try {
    (void)max_node_distance(mesh.nodes, Eigen::Matrix3Xd::Zero(3, 7));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("642 and 7 nodes"));
  }
  try {
    (void)shape_diagnostics(mesh, Eigen::Matrix3Xd::Zero(3, 7));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("configuration has 7 nodes, the mesh 642"));
  }
}

// diagnostics.csv is the same on any number of threads: area, volume and the inertia
// ellipsoid (hence D12) come out bit for bit equal on 1, 2 and 3 threads.
TEST(Diagnostics, SameBitsOnAnyNumberOfThreads) {
  for (const Order order : {Order::p1, Order::p2}) {
    const Mesh mesh = make_icosphere({.order = order, .level = 4, .radius = a});
    const Eigen::Matrix3Xd x = seed_ellipsoid(mesh.nodes, Eigen::Vector3d(0.1, -0.05, 0.02));
    const int before = omp_get_max_threads();
    std::vector<ShapeDiagnostics> d;
    for (const int threads : {1, 2, 3}) {
      omp_set_num_threads(threads);
      d.push_back(shape_diagnostics(mesh, x));
    }
    omp_set_num_threads(before);
    for (std::size_t k = 1; k < d.size(); ++k) {
      EXPECT_EQ(d[k].area, d[0].area) << k + 1 << " threads";
      EXPECT_EQ(d[k].volume, d[0].volume) << k + 1 << " threads";
      EXPECT_EQ(d[k].d12, d[0].d12) << k + 1 << " threads";
      EXPECT_EQ(d[k].centroid, d[0].centroid) << k + 1 << " threads";
    }
  }
}

}  // namespace
}  // namespace capsflow::membrane
