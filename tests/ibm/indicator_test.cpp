// The inside of a membrane on the tree (ibm/indicator.hpp): its integral converges to the
// enclosed volume at second order for a sphere and an ellipsoid; it is exactly 0 or 1 beyond
// the kernel's half support from the membrane and follows the kernel's profile across it;
// nodes on cell faces and cell centres on the membrane change nothing; a membrane across a
// periodic side counts through its image.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "geometry/triangle_surface.hpp"
#include "ibm/indicator.hpp"
#include "ibm_support.hpp"
#include "membrane/diagnostics.hpp"
#include "membrane/mesh.hpp"

namespace capsflow::ibm {
namespace {

using Eigen::Vector3d;

struct Membrane {
  membrane::Mesh mesh;
  std::vector<std::array<int, 3>> triangles;
  double volume = 0.0;  // of the flat triangles
};

Membrane ellipsoid(const Vector3d& semi_axes, const Vector3d& centre, int level = 5) {
  Membrane m;
  m.mesh = membrane::make_icosphere({.order = membrane::Order::p1, .level = level, .radius = 1.0});
  m.mesh.nodes = semi_axes.asDiagonal() * m.mesh.nodes;
  m.mesh.nodes.colwise() += centre;
  m.triangles = membrane::flat_triangles(m.mesh);
  m.volume = membrane::enclosed_volume(m.mesh, m.mesh.nodes);
  return m;
}

const tree::TreeOptions<3> kBox{.roots = {2, 2, 2}, .root_size = 1.0, .origin = {-1.0, -1.0, -1.0}, .max_level = 4};

double integral(const tree::Tree<3>& t, const std::vector<InsideCell>& inside) {
  double v = 0.0;
  for (const InsideCell& c : inside) v += c.value * std::pow(t.cell_size(t.level_of(c.cell)), 3);
  return v;
}

// |integral - volume| / volume on trees refined at the membrane to levels 4, 5 and 6 (and
// coarser inside and outside), with the observed orders.
std::vector<double> volume_errors(const Membrane& m, KernelKind kernel) {
  std::vector<double> errors;
  for (int level = 4; level <= 6; ++level) {
    tree::TreeOptions<3> o = kBox;
    o.max_level = level;
    const tree::Tree<3> t = test::refined_around(o, m.mesh.nodes, 4, 2);
    errors.push_back(std::abs(integral(t, inside_cells(t, m.mesh.nodes, m.triangles, kernel, level)) - m.volume) / m.volume);
  }
  return errors;
}

TEST(Indicator, SpheresIntegralConvergesToItsVolumeAtSecondOrder) {
  const auto e = volume_errors(ellipsoid(Vector3d::Constant(0.6), Vector3d(0.013, -0.021, 0.007)), KernelKind::cosine);
  const double order1 = std::log2(e[0] / e[1]), order2 = std::log2(e[1] / e[2]);
  std::printf("sphere: relative errors %.3e %.3e %.3e, orders %.2f %.2f\n", e[0], e[1], e[2], order1, order2);
  EXPECT_LT(e[2], 2e-3);
  EXPECT_GT(order1, 1.8);
  EXPECT_GT(order2, 1.8);
}

TEST(Indicator, EllipsoidsIntegralConvergesToItsVolumeAtSecondOrder) {
  for (const KernelKind kernel : {KernelKind::cosine, KernelKind::peskin4, KernelKind::hat}) {
    const auto e = volume_errors(ellipsoid(Vector3d(0.75, 0.45, 0.3), Vector3d(-0.031, 0.017, 0.009)), kernel);
    const double order1 = std::log2(e[0] / e[1]), order2 = std::log2(e[1] / e[2]);
    std::printf("ellipsoid, %s kernel: relative errors %.3e %.3e %.3e, orders %.2f %.2f\n",
                std::string(name_of(kernel)).c_str(), e[0], e[1], e[2], order1, order2);
    EXPECT_LT(e[2], 4e-3);
    EXPECT_GT(0.5 * (order1 + order2), 1.8);
  }
}

// Every owned leaf against the exact signed distance d of its centre to the flat triangles:
// beyond `beyond` cells (the half support 2h and the distance's plane error), exactly the
// side's 0 or 1; across the membrane, C(-d/h) to `tolerance`. The distance to a crossed
// triangle's plane is off by O(d^2 / R): at most 0.1 h (0.048 in I) on these membranes, whose
// least radius of curvature is 7 h.
void check_profile(const tree::Tree<3>& t, const Membrane& m, int level, double beyond, double tolerance) {
  geometry::TriangleMesh tm;
  tm.vertices = m.mesh.nodes;
  tm.triangles = m.triangles;
  const geometry::SolidPtr surface = geometry::triangle_surface(tm);
  std::vector<double> in(static_cast<std::size_t>(t.num_cells()), 0.0);
  for (const InsideCell& c : inside_cells(t, m.mesh.nodes, m.triangles, KernelKind::cosine, level)) {
    ASSERT_GT(c.value, 0.0);
    ASSERT_LE(c.value, 1.0);
    in[static_cast<std::size_t>(c.cell)] = c.value;
  }
  const double h = t.cell_size(level);
  int across = 0;
  double widest = 0.0, worst = 0.0;  // the farthest centre with 0 < I < 1 (in h); the largest profile error
  for (const tree::Index c : t.owned_leaves()) {
    const auto p = t.center(c);
    const double d = surface->signed_distance(Vector3d(p[0], p[1], p[2]));
    const double got = in[static_cast<std::size_t>(c)];
    if (got > 0.0 && got < 1.0) widest = std::max(widest, std::abs(d) / h);
    if (std::abs(d) > beyond * h) {
      ASSERT_EQ(got, d < 0 ? 1.0 : 0.0) << "at " << p[0] << " " << p[1] << " " << p[2] << ", distance " << d / h << " h";
    } else {
      ++across;
      worst = std::max(worst, std::abs(got - CosineKernel::cumulative(-d / h)));
    }
  }
  std::printf("%d centres within %.2f h; 0 < I < 1 up to %.3f h; largest error against C(-d/h) %.4f\n", across, beyond,
              widest, worst);
  EXPECT_GT(across, 1000);
  EXPECT_LE(worst, tolerance);
}

TEST(Indicator, ExactlyZeroOrOneAwayFromTheMembraneAndTheKernelsProfileAcrossIt) {
  const Membrane m = ellipsoid(Vector3d(0.7, 0.5, 0.4), Vector3d(0.02, -0.01, 0.03));
  tree::TreeOptions<3> o = kBox;
  o.max_level = 5;
  check_profile(test::refined_around(o, m.mesh.nodes, 4, 2), m, 5, 2.5, 0.06);
}

TEST(Indicator, NodesOnCellFacesAndCentresOnTheMembraneChangeNothing) {
  // Node 0 on a cell centre, a third of the nodes on the faces of the level-5 cells, the
  // others shifted onto the planes of cell centres.
  Membrane m = ellipsoid(Vector3d::Constant(0.55), Vector3d::Zero());
  const double h = 1.0 / 32;
  m.mesh.nodes.colwise() += Vector3d::Constant(0.5 * h) - m.mesh.nodes.col(0);
  int snapped = 0;
  for (Eigen::Index v = 1; v < m.mesh.nodes.cols(); ++v) {
    const double shift = v % 3 == 0 ? 0.0 : 0.5;  // faces, or centres
    const double on_plane = (std::round(m.mesh.nodes(v % 3, v) / h - shift) + shift) * h;
    if (std::abs(on_plane - m.mesh.nodes(v % 3, v)) < 0.05 * h) {  // keep the surface smooth
      m.mesh.nodes(v % 3, v) = on_plane;
      ++snapped;
    }
  }
  EXPECT_GT(snapped, 200);
  m.volume = membrane::enclosed_volume(m.mesh, m.mesh.nodes);
  tree::TreeOptions<3> o = kBox;
  o.max_level = 5;
  const tree::Tree<3> t = test::refined_around(o, m.mesh.nodes, 4, 2);
  check_profile(t, m, 5, 2.5, 0.06);
  // The same membrane moved off the grid's planes by a fraction of a cell: the integral
  // moves by its O(h^2) sampling error only.
  Membrane generic = m;
  generic.mesh.nodes.colwise() += Vector3d(0.0137, 0.0071, 0.0093) * h;
  const tree::Tree<3> u = test::refined_around(o, generic.mesh.nodes, 4, 2);
  const double on_grid = integral(t, inside_cells(t, m.mesh.nodes, m.triangles, KernelKind::cosine, 5));
  const double off_grid = integral(u, inside_cells(u, generic.mesh.nodes, generic.triangles, KernelKind::cosine, 5));
  std::printf("on the grid's planes %.6f, off them %.6f, enclosed %.6f\n", on_grid, off_grid, m.volume);
  EXPECT_NEAR(on_grid, off_grid, 2e-4 * m.volume);
}

TEST(Indicator, AMembraneAcrossAPeriodicSideCountsThroughItsImage) {
  tree::TreeOptions<3> o = kBox;
  o.max_level = 5;
  o.periodic = {true, false, true};
  const Membrane centred = ellipsoid(Vector3d(0.5, 0.4, 0.3), Vector3d(0.013, 0.0, 0.0));
  // The same membrane across the x and z sides (unwrapped nodes beyond the brick).
  const Membrane across = ellipsoid(Vector3d(0.5, 0.4, 0.3), Vector3d(1.013, 0.0, 1.0));
  const tree::Tree<3> t = test::refined_around(o, centred.mesh.nodes, 4, 2);
  const tree::Tree<3> u = test::refined_around(o, across.mesh.nodes, 4, 2);
  const double a = integral(t, inside_cells(t, centred.mesh.nodes, centred.triangles, KernelKind::cosine, 5));
  const double b = integral(u, inside_cells(u, across.mesh.nodes, across.triangles, KernelKind::cosine, 5));
  EXPECT_NEAR(a, centred.volume, 2e-2 * centred.volume);  // the smoothing's O(h^2) at h = a / 10
  EXPECT_NEAR(b, a, 1e-12 * a);
}

}  // namespace
}  // namespace capsflow::ibm
