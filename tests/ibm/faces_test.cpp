// Spreading to and interpolating from the MAC faces (spread_faces, interpolate_faces): a
// linear field sampled on the faces is interpolated exactly by hat and Peskin, face
// spreading keeps the total force, and the two are adjoint to round-off for every kernel,
// sum_X V(X).F(X) = sum_faces uf f dx^3.
#include <gtest/gtest.h>

#include <random>

#include "ibm/interpolate.hpp"
#include "ibm/spread.hpp"
#include "ibm_support.hpp"

namespace capsflow::ibm {
namespace {

const tree::TreeOptions<3> kCube{
    .roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .max_level = 5};

const Eigen::Vector3d kA(0.3, -1.2, 0.7);
const Eigen::Matrix3d kB = (Eigen::Matrix3d() << 1.5, -0.4, 2.0, 0.3, 0.9, -1.1, -2.2, 0.6, 0.25).finished();

// Component d of f at the lower face of every max-level active cell normal to d.
template <class F>
fluid::FaceField<3> on_faces(const tree::Tree<3>& t, F&& f) {
  fluid::FaceField<3> u;
  fluid::resize<3>(u, t);
  const int l = t.max_level();
  const double h = t.cell_size(l);
  const auto& lv = t.level(l);
  for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
    for (int d = 0; d < 3; ++d) {
      const auto p = t.center(c);
      Eigen::Vector3d x(p[0], p[1], p[2]);
      x[d] -= 0.5 * h;
      u[d][c] = f(d, x);
    }
  return u;
}

template <Kernel K>
double face_linear_error(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x) {
  const auto uf = on_faces(t, [](int d, const Eigen::Vector3d& p) { return (kA + kB * p)[d]; });
  Eigen::Matrix3Xd v;
  interpolate_faces<K>(t, uf, x, v);
  double worst = 0.0;
  for (Eigen::Index i = 0; i < x.cols(); ++i)
    worst = std::max(worst, (v.col(i) - (kA + kB * x.col(i))).cwiseAbs().maxCoeff());
  return worst;
}

TEST(Faces, LinearFieldsExactForHatAndPeskin) {
  const Eigen::Matrix3Xd x = test::random_ball(800, 0.6, Eigen::Vector3d(0.02, -0.03, 0.01), 21);
  const tree::Tree<3> t = test::refined_around(kCube, x, 3);
  const double hat = face_linear_error<HatKernel>(t, x), peskin = face_linear_error<Peskin4Kernel>(t, x);
  std::printf("linear field on faces: max error hat %.2e, peskin4 %.2e\n", hat, peskin);
  EXPECT_LT(hat, 1e-13);
  EXPECT_LT(peskin, 1e-13);
}

template <Kernel K>
void check_adjoint_and_total(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x) {
  const Eigen::Matrix3Xd F = test::random_forces(x.cols(), 5);
  std::mt19937 gen(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const auto uf = on_faces(t, [&](int, const Eigen::Vector3d&) { return u(gen); });
  fluid::FaceField<3> f;
  SpreadWorkspace ws;
  spread_faces<K>(t, x, F, f, ws);
  Eigen::Matrix3Xd v;
  interpolate_faces<K>(t, uf, x, v);
  const int l = t.max_level();
  const double vol = std::pow(t.cell_size(l), 3);
  const auto& lv = t.level(l);
  double grid = 0.0, scale = 0.0;
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (Index c = lv.active_begin(); c < lv.active_end(); ++c)
    for (int d = 0; d < 3; ++d) {
      grid += uf[d][c] * f[d][c] * vol;
      scale += std::abs(uf[d][c] * f[d][c] * vol);
      total[d] += f[d][c] * vol;
    }
  const double nodes = (v.array() * F.array()).sum();
  EXPECT_LT(std::abs(grid - nodes), 1e-13 * scale) << K::kName;
  EXPECT_LT((total - F.rowwise().sum()).cwiseAbs().maxCoeff(), 1e-12) << K::kName;
}

TEST(Faces, SpreadingIsTheAdjointOfInterpolationAndKeepsTheForce) {
  const Eigen::Matrix3Xd x = test::random_ball(500, 0.6, Eigen::Vector3d(0.01, 0.02, -0.02), 33);
  const tree::Tree<3> t = test::refined_around(kCube, x, 3);
  check_adjoint_and_total<CosineKernel>(t, x);
  check_adjoint_and_total<HatKernel>(t, x);
  check_adjoint_and_total<Peskin4Kernel>(t, x);
}

}  // namespace
}  // namespace capsflow::ibm
