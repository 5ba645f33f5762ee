// Spreading and interpolation next to an embedded wall (wall_weights.hpp), around a ball
// whose wall cuts the stencils at every angle: the open fractions are the solver's own face
// fractions; a node's spread force lands on open faces only and sums, weighted by the faces'
// fluid volumes, to the node's force; interpolation is its adjoint in that inner product
// and reads a constant velocity exactly; nodes clear of the walls keep the plain kernel to
// the last bit.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fluid/embedded_geometry.hpp"
#include "fluid/energy.hpp"
#include "geometry/solid.hpp"
#include "ibm/interpolate.hpp"
#include "ibm/spread.hpp"
#include "ibm/wall_weights.hpp"
#include "ibm_support.hpp"

namespace capsflow::ibm {
namespace {

const tree::TreeOptions<3> kCube{.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .max_level = 5};
constexpr double kRadius = 0.37;  // off the grid

// Points at distances from dx/4 to 3 dx outside the ball, in every direction.
Eigen::Matrix3Xd near_ball(int n, double dx, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> gap(0.25 * dx, 3.0 * dx);
  Eigen::Matrix3Xd x(3, n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    x.col(i) = (kRadius + gap(rng)) * dir;
  }
  return x;
}

struct BallScene {
  geometry::SolidPtr ball = geometry::sphere(Eigen::Vector3d::Zero(), kRadius);
  Eigen::Matrix3Xd x;
  tree::Tree<3> t;
  fluid::EmbeddedGeometry<3> walls;
  double dx;
  WallWeights weights;
  explicit BallScene(Eigen::Matrix3Xd nodes)
      : x(std::move(nodes)), t(test::refined_around(kCube, x, 3)), walls(t, ball), dx(t.cell_size(t.max_level())) {
    weights.find(KernelKind::cosine, true, walls, t, x, 1.0);
  }
};

using Kernel = DivergenceFree<CosineKernel>;

// sum over the max-level faces of a_f f_f dx^3, per component.
Eigen::Vector3d fluid_total(const BallScene& s, const fluid::FaceField<3>& f) {
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  const auto& lv = s.t.level(s.t.max_level());
  for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
    for (int d = 0; d < 3; ++d) total[d] += s.walls.faces()[d][c] * f[d][c];
  return total * s.dx * s.dx * s.dx;
}

TEST(WallWeights, OpenFractionsAreTheSolversFaceFractions) {
  const BallScene s(near_ball(200, 1.0 / 16, 3));
  ASSERT_EQ(s.weights.nodes(), 200);
  int renormalised = 0;
  for (Eigen::Index i = 0; i < s.x.cols(); ++i)
    for (int d = 0; d < 3; ++d) {
      const double* open = s.weights.open(i, d);
      if (!open) continue;
      ++renormalised;
      const BoxStencil st = face_stencil<Kernel>(s.t.options(), s.dx, &s.x(0, i), d);
      std::vector<Index> cells(static_cast<std::size_t>(st.size()));
      ASSERT_LT(find_box(s.t, s.t.max_level(), st.first, st.n, cells.data()), 0);
      for (int k = 0; k < st.size(); ++k) ASSERT_EQ(open[k], s.walls.faces()[d][cells[static_cast<std::size_t>(k)]]);
    }
  EXPECT_GT(renormalised, 400);  // nearly every node's stencils are cut
}

TEST(WallWeights, ANodesSpreadForceLandsOnOpenFacesAndSumsToTheNodeForce) {
  const BallScene s(near_ball(60, 1.0 / 16, 5));
  SpreadWorkspace ws;
  int cut = 0;
  for (Eigen::Index i = 0; i < s.x.cols(); ++i) {
    const Eigen::Matrix3Xd xi = s.x.col(i);
    WallWeights one;
    one.find(KernelKind::cosine, true, s.walls, s.t, xi, 1.0);
    const double k = static_cast<double>(i);
    const Eigen::Vector3d force(0.3 - 0.01 * k, -1.1, 0.7 + 0.02 * k);
    fluid::FaceField<3> f;
    spread_faces<Kernel>(s.t, xi, force, f, ws, SpreadMode::assign, {}, nullptr, &one);
    EXPECT_LT((fluid_total(s, f) - force).cwiseAbs().maxCoeff(), 1e-13 * force.norm()) << "node " << i;
    // No closed face, and so no face of a solid cell, receives anything.
    const auto& lv = s.t.level(s.t.max_level());
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
      for (int d = 0; d < 3; ++d)
        if (s.walls.faces()[d][c] == 0.0) {
          ASSERT_EQ(f[d][c], 0.0) << "node " << i << " face " << c;
        }
    for (int d = 0; d < 3; ++d) cut += one.open(0, d) != nullptr;
  }
  EXPECT_GT(cut, 100);
}

TEST(WallWeights, InterpolationIsSpreadingsAdjointInTheFluidInnerProduct) {
  const BallScene s(near_ball(300, 1.0 / 16, 7));
  const Eigen::Matrix3Xd forces = test::random_forces(s.x.cols(), 11);
  fluid::FaceField<3> f, uf;
  SpreadWorkspace ws;
  spread_faces<Kernel>(s.t, s.x, forces, f, ws, SpreadMode::assign, {}, nullptr, &s.weights);
  fluid::resize<3>(uf, s.t);
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (auto& ud : uf)
    for (double& v : ud) v = u(rng);
  Eigen::Matrix3Xd v;
  interpolate_faces<Kernel>(s.t, uf, s.x, v, nullptr, &s.weights);
  double faces = 0.0;
  const auto& lv = s.t.level(s.t.max_level());
  for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
    for (int d = 0; d < 3; ++d) faces += s.walls.faces()[d][c] * f[d][c] * uf[d][c];
  faces *= s.dx * s.dx * s.dx;
  const double nodes = (v.array() * forces.array()).sum();
  EXPECT_NEAR(faces, nodes, 1e-12 * forces.cwiseAbs().sum());
  // The same through the flow's energy budget (face_power with the open fractions).
  EXPECT_NEAR(fluid::face_power<3>(s.t, f, uf, &s.walls.faces()), nodes, 1e-12 * forces.cwiseAbs().sum());
}

TEST(WallWeights, InterpolationReadsAConstantVelocityExactly) {
  const BallScene s(near_ball(300, 1.0 / 16, 17));
  fluid::FaceField<3> uf;
  fluid::resize<3>(uf, s.t);
  const Eigen::Vector3d c(0.7, -0.2, 1.3);
  for (int d = 0; d < 3; ++d)
    for (Index k = 0; k < s.t.num_cells(); ++k)  // the solid's faces hold garbage: never read
      uf[d][static_cast<std::size_t>(k)] = s.walls.faces()[d][static_cast<std::size_t>(k)] > 0.0 ? c[d] : 1e6;
  Eigen::Matrix3Xd v;
  interpolate_faces<Kernel>(s.t, uf, s.x, v, nullptr, &s.weights);
  EXPECT_LT((v.colwise() - c).cwiseAbs().maxCoeff(), 1e-13);
  interpolate_faces<Kernel>(s.t, uf, s.x, v);  // without the weights the solid is read
  EXPECT_GT((v.colwise() - c).cwiseAbs().maxCoeff(), 1.0);
}

TEST(WallWeights, NodesClearOfTheWallsKeepThePlainKernelToTheBit) {
  // A ring at 5 cells from the ball: within reach 1.0, every face of every stencil open.
  Eigen::Matrix3Xd x(3, 64);
  for (int i = 0; i < 64; ++i) {
    const double a = 2.0 * M_PI * i / 64.0;
    x.col(i) = (kRadius + 5.0 / 16) * Eigen::Vector3d(std::cos(a), std::sin(a), 0.1);
  }
  const BallScene s(x);
  EXPECT_EQ(s.weights.near_nodes(), 64);
  for (Eigen::Index i = 0; i < 64; ++i)
    for (int d = 0; d < 3; ++d) EXPECT_EQ(s.weights.open(i, d), nullptr);
  const Eigen::Matrix3Xd forces = test::random_forces(64, 19);
  fluid::FaceField<3> with, without;
  SpreadWorkspace ws;
  spread_faces<Kernel>(s.t, s.x, forces, with, ws, SpreadMode::assign, {}, nullptr, &s.weights);
  spread_faces<Kernel>(s.t, s.x, forces, without, ws);
  for (int d = 0; d < 3; ++d) EXPECT_EQ(with[d], without[d]);
}

TEST(WallWeights, ANodeInsideTheSolidIsReported) {
  Eigen::Matrix3Xd x = near_ball(20, 1.0 / 16, 23);
  x.col(7) = Eigen::Vector3d(0.05, -0.02, 0.03);  // deep inside the ball
  const BallScene s(x);
  EXPECT_EQ(s.weights.buried(), 7);
}

}  // namespace
}  // namespace capsflow::ibm
