// Cut cells from corner values: exact for plane walls, the discrete divergence theorem to
// rounding, complementary cuts, and the same face fraction from either side of a face.
#include "geometry/cut_cell.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include <Eigen/Geometry>

namespace capsflow::geometry {
namespace {

// The measure of {x in [0,1]^N : n.x <= alpha} for n > 0 (inclusion-exclusion over the
// cube's corners: Scardovelli & Zaleski, J. Comput. Phys. 164, 2000).
template <int N>
double below_plane(const std::array<double, N>& n, double alpha) {
  double sum = 0.0, product = 1.0, factorial = 1.0;
  for (int i = 0; i < N; ++i) {
    product *= n[i];
    factorial *= i + 1;
  }
  for (int s = 0; s < (1 << N); ++s) {
    double shift = 0.0;
    int bits = 0;
    for (int i = 0; i < N; ++i)
      if (s >> i & 1) {
        shift += n[i];
        ++bits;
      }
    sum += (bits % 2 ? -1.0 : 1.0) * std::pow(std::max(0.0, alpha - shift), N);
  }
  return sum / (factorial * product);
}

// Corner values of phi(x) = n.x - alpha on the unit cell (fluid where n.x >= alpha).
template <int D>
std::array<double, (1 << D)> plane_corners(const std::array<double, D>& n, double alpha) {
  std::array<double, (1 << D)> phi{};
  for (int b = 0; b < (1 << D); ++b) {
    double v = -alpha;
    for (int d = 0; d < D; ++d) v += n[d] * (b >> d & 1);
    phi[b] = v;
  }
  return phi;
}

template <int D>
void check_plane(std::mt19937& rng) {
  std::uniform_real_distribution<double> component(0.05, 1.0), sign(0.0, 1.0);
  std::array<double, D> n{}, positive{};
  for (int d = 0; d < D; ++d) {
    positive[d] = component(rng);
    n[d] = sign(rng) < 0.5 ? -positive[d] : positive[d];
  }
  double length = 0.0, sum_pos = 0.0;
  for (int d = 0; d < D; ++d) {
    length += n[d] * n[d];
    sum_pos += positive[d];
  }
  length = std::sqrt(length);
  // With y_d = x_d where n_d > 0 and 1 - x_d where n_d < 0, n.x = positive.y - shift: the
  // fluid n.x >= alpha - shift is positive.y >= alpha, whose measure the formula gives.
  const double alpha = std::uniform_real_distribution<double>(0.0, sum_pos)(rng);
  double shift = 0.0;
  for (int d = 0; d < D; ++d)
    if (n[d] < 0.0) shift += positive[d];
  const CellCut<D> c = cut_cell<D>(plane_corners<D>(n, alpha - shift));
  const double fluid = 1.0 - below_plane<D>(positive, alpha);
  EXPECT_NEAR(c.volume, fluid, 1e-13);
  // The wall: the plane's part inside the cell, area = the faces' imbalance along the normal.
  for (int d = 0; d < D; ++d) EXPECT_NEAR(c.wall[d], c.face[2 * d] - c.face[2 * d + 1], 1e-13);
  if (fluid > 1e-9 && fluid < 1.0 - 1e-9) {
    ASSERT_GT(c.wall_area, 0.0);
    double on_plane = -(alpha - shift), normal_dot = 0.0;
    for (int d = 0; d < D; ++d) {
      on_plane += n[d] * c.wall_centroid[d];
      normal_dot += c.wall[d] * n[d] / length;
    }
    EXPECT_NEAR(on_plane, 0.0, 1e-12) << "the wall's centroid lies on the plane";
    EXPECT_NEAR(normal_dot, -c.wall_area, 1e-12) << "the wall's normal is the plane's, into the solid";
  }
}

TEST(CutCell, PlaneWallsAreExact2D) {
  std::mt19937 rng(7);
  for (int i = 0; i < 2000; ++i) check_plane<2>(rng);
}

TEST(CutCell, PlaneWallsAreExact3D) {
  std::mt19937 rng(11);
  for (int i = 0; i < 2000; ++i) check_plane<3>(rng);
}

TEST(CutCell, ACornerTetrahedronHasItsClosedForm) {
  // x + y + z >= s is solid near the origin for phi = x + y + z - s: a solid corner of
  // volume s^3 / 6 and a wall triangle of area sqrt(3) s^2 / 2.
  for (const double s : {0.1, 0.5, 0.9}) {
    const CellCut<3> c = cut_cell<3>(plane_corners<3>({1.0, 1.0, 1.0}, s));
    EXPECT_NEAR(c.volume, 1.0 - s * s * s / 6.0, 1e-15);
    EXPECT_NEAR(c.wall_area, std::sqrt(3.0) * s * s / 2.0, 1e-15);
    EXPECT_NEAR(c.face[0], 1.0 - s * s / 2.0, 1e-15);
    EXPECT_DOUBLE_EQ(c.face[1], 1.0);
  }
}

template <int D>
void check_random_corners(std::mt19937& rng) {
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::array<double, (1 << D)> phi{}, minus{};
  for (int b = 0; b < (1 << D); ++b) {
    phi[b] = value(rng);
    minus[b] = -phi[b];
  }
  const CellCut<D> c = cut_cell<D>(phi), m = cut_cell<D>(minus);
  EXPECT_GE(c.volume, 0.0);
  EXPECT_LE(c.volume, 1.0);
  // The divergence theorem, wall included, for a wall that is not a plane.
  for (int d = 0; d < D; ++d) EXPECT_NEAR(c.wall[d], c.face[2 * d] - c.face[2 * d + 1], 1e-13);
  double magnitude = 0.0;
  for (int d = 0; d < D; ++d) magnitude += c.wall[d] * c.wall[d];
  EXPECT_LE(std::sqrt(magnitude), c.wall_area + 1e-13) << "a bent wall's area vector is shorter than its area";
  // The solid of phi is the fluid of -phi: volumes and faces complementary, the same wall.
  EXPECT_NEAR(c.volume + m.volume, 1.0, 1e-13);
  for (int k = 0; k < 2 * D; ++k) EXPECT_NEAR(c.face[k] + m.face[k], 1.0, 1e-13);
  EXPECT_NEAR(c.wall_area, m.wall_area, 1e-13);
  for (int d = 0; d < D; ++d) {
    EXPECT_NEAR(c.wall[d], -m.wall[d], 1e-13);
    EXPECT_GE(c.wall_centroid[d], -1e-15);
    EXPECT_LE(c.wall_centroid[d], 1.0 + 1e-15);
  }
}

TEST(CutCell, BentWallsKeepTheDivergenceTheoremAndComplement) {
  std::mt19937 rng(3);
  for (int i = 0; i < 3000; ++i) {
    check_random_corners<2>(rng);
    check_random_corners<3>(rng);
  }
}

TEST(CutCell, NeighboursAgreeOnTheirSharedFace) {
  // Two cells side by side along each axis, on a random corner field of a 2x1x1 block: the
  // upper face of the first is the lower face of the second.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  for (int i = 0; i < 500; ++i)
    for (int d = 0; d < 3; ++d) {
      std::array<double, 12> block{};  // corners (i, j, k), index along d in 0..2
      for (double& v : block) v = value(rng);
      auto cell = [&](int offset) {
        std::array<double, 8> phi{};
        for (int b = 0; b < 8; ++b) {
          const int along = (b >> d & 1) + offset;
          const int rest = b & ~(1 << d);  // the other two bits, in place
          const int r0 = d == 0 ? (rest >> 1 & 1) : (rest & 1), r1 = d == 2 ? (rest >> 1 & 1) : (rest >> 2 & 1);
          phi[b] = block[static_cast<std::size_t>(along * 4 + r0 * 2 + r1)];
        }
        return cut_cell<3>(phi);
      };
      EXPECT_DOUBLE_EQ(cell(0).face[2 * d + 1], cell(1).face[2 * d]);
    }
}

TEST(CutCell, UncutCellsAreFullOrEmpty) {
  const CellCut<3> full = cut_cell<3>({1e-300, 1.0, 2.0, 0.5, 0.1, 0.2, 0.3, 0.4});
  EXPECT_EQ(full.volume, 1.0);
  EXPECT_FALSE(full.cut());
  for (const double f : full.face) EXPECT_EQ(f, 1.0);
  const CellCut<2> empty = cut_cell<2>({-1.0, -2.0, -0.5, -1e-300});
  EXPECT_EQ(empty.volume, 0.0);
  for (const double f : empty.face) EXPECT_EQ(f, 0.0);
}

TEST(CutCell, AWallOnAFaceIsTheFluidCellsOwn) {
  // phi = 1 - x: zero on the cell's upper x face, fluid below it.
  const CellCut<3> inside = cut_cell<3>(plane_corners<3>({-1.0, 0.0, 0.0}, -1.0));
  // Exactly full (the operators then give it the constant stencil without that face).
  EXPECT_EQ(inside.volume, 1.0);
  EXPECT_DOUBLE_EQ(inside.face[1], 0.0) << "the face the wall lies on is closed";
  EXPECT_DOUBLE_EQ(inside.face[0], 1.0);
  EXPECT_DOUBLE_EQ(inside.wall_area, 1.0);
  EXPECT_DOUBLE_EQ(inside.wall[0], 1.0) << "the normal points into the solid, +x";
  EXPECT_DOUBLE_EQ(inside.wall_centroid[0], 1.0);
  // The cell beyond (phi = -x on its own unit cell) is empty, with every face closed.
  const CellCut<3> beyond = cut_cell<3>(plane_corners<3>({-1.0, 0.0, 0.0}, 0.0));
  EXPECT_EQ(beyond.volume, 0.0);
  for (const double f : beyond.face) EXPECT_EQ(f, 0.0);
  // A wall through one corner only is no wall: a full, uncut cell.
  const CellCut<2> corner = cut_cell<2>({0.0, 1.0, 1.0, 2.0});
  EXPECT_EQ(corner.volume, 1.0);
  EXPECT_FALSE(corner.cut());
}

}  // namespace
}  // namespace capsflow::geometry

namespace capsflow::geometry {
namespace {

// The wall as triangles (for ParaView) is the wall cut_cell measures: on random bent walls
// their areas sum to its area and their oriented area vectors (out of the solid) to minus
// its area vector (into the solid); every vertex lies in the cell.
TEST(CutCell, WallTrianglesAreTheMeasuredWall) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int cut_cells = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::array<double, 8> phi{};
    for (double& v : phi) v = u(rng);
    if (trial % 7 == 0) phi[static_cast<std::size_t>(trial % 8)] = 0.0;  // a corner on the wall
    const CellCut<3> cut = cut_cell<3>(phi);
    const auto triangles = wall_triangles(phi);
    Eigen::Vector3d vector = Eigen::Vector3d::Zero();
    double area = 0.0;
    for (const auto& t : triangles) {
      const Eigen::Vector3d a(t[0], t[1], t[2]), b(t[3], t[4], t[5]), c(t[6], t[7], t[8]);
      for (const Eigen::Vector3d& p : {a, b, c}) ASSERT_TRUE((p.array() >= -1e-15).all() && (p.array() <= 1 + 1e-15).all());
      const Eigen::Vector3d v = 0.5 * (b - a).cross(c - a);
      vector += v;
      area += v.norm();
    }
    EXPECT_NEAR(area, cut.wall_area, 1e-13) << "trial " << trial;
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(vector[d], -cut.wall[static_cast<std::size_t>(d)], 1e-13) << "trial " << trial;
    EXPECT_EQ(triangles.empty(), !cut.cut()) << "trial " << trial;
    cut_cells += cut.cut();
  }
  EXPECT_GT(cut_cells, 1500);
  EXPECT_TRUE(wall_triangles({1, 1, 1, 1, 1, 1, 1, 1}).empty());
}

}  // namespace
}  // namespace capsflow::geometry
