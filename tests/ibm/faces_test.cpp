// Spreading to and interpolating from the MAC faces (spread_faces, interpolate_faces): a
// linear field sampled on the faces is interpolated exactly by hat and Peskin, face
// spreading keeps the total force, and the two are adjoint to round-off for every kernel,
// sum_X V(X).F(X) = sum_faces uf f dx^3; with the kernels' divergence-free forms
// (DivergenceFree<K>, Bao et al. 2017) the interpolated field of a discretely
// divergence-free face velocity is divergence-free as a function of the position.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <utility>

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
  // psi = phi * box reproduces linear fields wherever phi does at every offset.
  const tree::Tree<3> wide = test::refined_around(kCube, x, 4);
  const double dhat = face_linear_error<DivergenceFree<HatKernel>>(wide, x),
               dpeskin = face_linear_error<DivergenceFree<Peskin4Kernel>>(wide, x);
  std::printf("divergence-free forms: max error hat %.2e, peskin4 %.2e\n", dhat, dpeskin);
  EXPECT_LT(dhat, 1e-13);
  EXPECT_LT(dpeskin, 1e-13);
}

// A face velocity that is discretely divergence-free to round-off and not polynomial: the
// discrete curl of a smooth vector potential A sampled on the cell edges (component d of
// A on the edges along d), uf = curl_h A.
fluid::FaceField<3> discrete_curl(const tree::Tree<3>& t) {
  const auto a = [](int d, const Eigen::Vector3d& p) {
    switch (d) {
      case 0: return std::sin(2.1 * p[1] + 0.3) * std::cos(1.7 * p[2]) + 0.4 * p[1] * p[2];
      case 1: return std::cos(1.3 * p[0] - 0.2) * std::sin(2.4 * p[2] + 0.5) - 0.3 * p[0] * p[0];
      default: return std::sin(1.9 * p[0] + 2.2 * p[1]) + 0.2 * p[1] * p[1] * p[0];
    }
  };
  const double h = t.cell_size(t.max_level());
  return on_faces(t, [&](int d, const Eigen::Vector3d& p) {
    // (curl A)_d = d_e A_f - d_f A_e with (d, e, f) cyclic; A_f lies on the edges at p +- h/2
    // along e, A_e at p +- h/2 along f.
    const int e = (d + 1) % 3, f = (d + 2) % 3;
    const auto at = [&](int axis, double s) {
      Eigen::Vector3d q = p;
      q[axis] += s * h;
      return q;
    };
    return (a(f, at(e, 0.5)) - a(f, at(e, -0.5)) - a(e, at(f, 0.5)) + a(e, at(f, -0.5))) / h;
  });
}

// max over x of |div V| by central differences of step eps, and max |grad V| as a scale.
template <Kernel K>
std::pair<double, double> interpolated_divergence(const tree::Tree<3>& t, const fluid::FaceField<3>& uf,
                                                  const Eigen::Matrix3Xd& x, double eps) {
  double div = 0.0, scale = 0.0;
  std::array<Eigen::Matrix3Xd, 3> plus, minus;
  for (int d = 0; d < 3; ++d) {
    Eigen::Matrix3Xd xp = x, xm = x;
    xp.row(d).array() += eps;
    xm.row(d).array() -= eps;
    interpolate_faces<K>(t, uf, xp, plus[d]);
    interpolate_faces<K>(t, uf, xm, minus[d]);
  }
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    double sum = 0.0;
    for (int d = 0; d < 3; ++d) {
      const Eigen::Vector3d g = (plus[d].col(i) - minus[d].col(i)) / (2.0 * eps);
      sum += g[d];
      scale = std::max(scale, g.cwiseAbs().maxCoeff());
    }
    div = std::max(div, std::abs(sum));
  }
  return {div, scale};
}

template <Kernel K>
void check_divergence_free(const tree::Tree<3>& t, const fluid::FaceField<3>& uf, const Eigen::Matrix3Xd& x) {
  const double eps = 1e-5;
  const auto [plain, s1] = interpolated_divergence<K>(t, uf, x, eps);
  const auto [free, s2] = interpolated_divergence<DivergenceFree<K>>(t, uf, x, eps);
  std::printf("%s: max |div V| / max |grad V| = %.2e (face kernel), %.2e (divergence-free form)\n",
              std::string(K::kName).c_str(), plain / s1, free / s2);
  // Central differences of step eps: truncation ~ eps^2 |V'''|, rounding ~ 1e-16 |V| / eps.
  EXPECT_LT(free, 1e-8 * s2) << K::kName;
  EXPECT_GT(plain, 1e-3 * s1) << K::kName;
}

TEST(Faces, DivergenceFreeFormsInterpolateDivergenceFreeFields) {
  const Eigen::Matrix3Xd x = test::random_ball(300, 0.5, Eigen::Vector3d(0.01, -0.02, 0.03), 45);
  const tree::Tree<3> t = test::refined_around(kCube, x, 4);
  const auto uf = discrete_curl(t);
  // The face field is discretely divergence-free on every max-level cell.
  const int l = t.max_level();
  const double h = t.cell_size(l);
  const auto& lv = t.level(l);
  double worst = 0.0, size = 0.0;
  for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
    double div = 0.0;
    bool inner = true;
    for (int d = 0; d < 3; ++d) {
      const Index up = lv.neighbor(c, tree::face_slot(d, 1));
      if (up == tree::kNone || up < lv.active_begin() || up >= lv.active_end()) inner = false;
      else div += (uf[d][up] - uf[d][c]) / h;
      size = std::max(size, std::abs(uf[d][c]));
    }
    if (inner) worst = std::max(worst, std::abs(div));
  }
  EXPECT_LT(worst * h, 1e-13 * size);
  check_divergence_free<CosineKernel>(t, uf, x);
  check_divergence_free<HatKernel>(t, uf, x);
  check_divergence_free<Peskin4Kernel>(t, uf, x);
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
  const tree::Tree<3> wide = test::refined_around(kCube, x, 4);
  check_adjoint_and_total<DivergenceFree<CosineKernel>>(wide, x);
  check_adjoint_and_total<DivergenceFree<HatKernel>>(wide, x);
  check_adjoint_and_total<DivergenceFree<Peskin4Kernel>>(wide, x);
}

}  // namespace
}  // namespace capsflow::ibm
