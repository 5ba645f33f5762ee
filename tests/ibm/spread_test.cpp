// Spreading: total force and torque of the cell force density against the point forces,
// for random node clouds and each kernel; thread-count independence; the face force; a
// periodic wrap.
#include <gtest/gtest.h>
#include <omp.h>

#include <cstring>

#include "ibm/spread.hpp"
#include "ibm_support.hpp"

namespace capsflow::ibm {
namespace {

using test::cell_totals;

const tree::TreeOptions<3> kBrick{.roots = {2, 1, 1}, .root_size = 1.0, .max_level = 5};

struct Cloud {
  Eigen::Matrix3Xd x, f;
  tree::Tree<3> t;
};

Cloud cloud(const tree::TreeOptions<3>& o, const Eigen::Vector3d& centre, unsigned seed) {
  Eigen::Matrix3Xd x = test::random_ball(600, 0.3, centre, seed);
  Eigen::Matrix3Xd f = test::random_forces(x.cols(), seed + 1);
  tree::Tree<3> t = test::refined_around(o, x, 3);
  return {std::move(x), std::move(f), std::move(t)};
}

// Totals of the point forces: sum F and sum (X + shift(X) - p) x F.
template <class Shift>
test::Totals point_totals(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& f, const Eigen::Vector3d& p,
                          Shift&& shift) {
  test::Totals s;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    s.force += f.col(i);
    s.torque += (Eigen::Vector3d(x.col(i)) + shift(Eigen::Vector3d(x.col(i))) - p).cross(Eigen::Vector3d(f.col(i)));
  }
  return s;
}

template <Kernel K>
void check_conservation(const Cloud& c, const Eigen::Vector3d& p) {
  CellVector f;
  SpreadWorkspace ws;
  spread<K>(c.t, c.x, c.f, f, ws);
  const auto cells = cell_totals(c.t, f, p);
  const double h = c.t.cell_size(c.t.max_level());
  const auto exact = point_totals(c.x, c.f, p, [](const Eigen::Vector3d&) { return Eigen::Vector3d::Zero(); });
  const double fscale = c.f.colwise().norm().sum();
  const double tscale = fscale * ((c.x.colwise() - p).colwise().norm().maxCoeff() + 2 * h);
  const double force_error = (cells.force - exact.force).norm() / fscale;
  EXPECT_LT(force_error, 1e-14) << K::kName;
  const double torque_error = (cells.torque - exact.torque).norm() / tscale;
  if constexpr (std::is_same_v<K, CosineKernel>) {
    // The cosine kernel shifts each force's line of action by dx m(r) (kernels.hpp): the
    // torque is that of the shifted forces to round-off, and the plain torque is off by
    // at most sqrt(3) 0.0211 dx per unit force.
    const auto shifted = point_totals(c.x, c.f, p, [&](const Eigen::Vector3d& xi) {
      const Eigen::Vector3d r = test::offsets(c.t, xi);
      return Eigen::Vector3d(h * test::cosine_first_moment(r[0]), h * test::cosine_first_moment(r[1]),
                             h * test::cosine_first_moment(r[2]));
    });
    const double shifted_error = (cells.torque - shifted.torque).norm() / tscale;
    EXPECT_LT(shifted_error, 1e-14);
    EXPECT_LT((cells.torque - exact.torque).norm(), std::sqrt(3.0) * 0.0211 * h * fscale);
    std::printf("%-8s force error %.2e, torque error %.2e (vs shifted forces %.2e)\n", K::kName.data(),
                force_error, torque_error, shifted_error);
  } else {
    EXPECT_LT(torque_error, 1e-14) << K::kName;
    std::printf("%-8s force error %.2e, torque error %.2e\n", K::kName.data(), force_error, torque_error);
  }
}

TEST(Spread, ConservesForceAndTorque) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const Cloud c = cloud(kBrick, {1.02, 0.49, 0.53}, seed);
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1.3, -0.7, 2.1)}) {
      check_conservation<CosineKernel>(c, p);
      check_conservation<HatKernel>(c, p);
      check_conservation<Peskin4Kernel>(c, p);
    }
  }
}

// Grid-aligned nodes (offsets 0 or 1/2 along every axis): the cosine kernel's first
// moment vanishes there, so it conserves the torque exactly too.
TEST(Spread, CosineConservesTorqueAtAlignedNodes) {
  Cloud c = cloud(kBrick, {1.0, 0.5, 0.5}, 7);
  const double h = c.t.cell_size(c.t.max_level());
  for (Eigen::Index i = 0; i < c.x.cols(); ++i)
    for (int d = 0; d < 3; ++d) c.x(d, i) = 0.5 * h * std::round(c.x(d, i) / (0.5 * h));
  CellVector f;
  SpreadWorkspace ws;
  spread<CosineKernel>(c.t, c.x, c.f, f, ws);
  const Eigen::Vector3d p(0.2, 0.3, -0.1);
  const auto cells = cell_totals(c.t, f, p);
  const auto exact = point_totals(c.x, c.f, p, [](const Eigen::Vector3d&) { return Eigen::Vector3d::Zero(); });
  EXPECT_LT((cells.torque - exact.torque).norm(), 1e-13 * c.f.colwise().norm().sum());
}

TEST(Spread, BitwiseIndependentOfThreadCount) {
  const Cloud c = cloud(kBrick, {0.97, 0.51, 0.48}, 11);
  for (KernelKind kind : {KernelKind::cosine, KernelKind::hat, KernelKind::peskin4}) {
    CellVector f1, f2;
    SpreadWorkspace ws;
    const int before = omp_get_max_threads();
    omp_set_num_threads(1);
    spread(kind, c.t, c.x, c.f, f1, ws);
    omp_set_num_threads(2);
    spread(kind, c.t, c.x, c.f, f2, ws);
    omp_set_num_threads(3);  // an odd split of the cell ranges
    CellVector f3;
    spread(kind, c.t, c.x, c.f, f3, ws);
    omp_set_num_threads(before);
    for (int d = 0; d < 3; ++d) {
      ASSERT_EQ(f1[d].size(), f2[d].size());
      EXPECT_EQ(std::memcmp(f1[d].data(), f2[d].data(), f1[d].size() * sizeof(double)), 0) << name_of(kind);
      EXPECT_EQ(std::memcmp(f1[d].data(), f3[d].data(), f1[d].size() * sizeof(double)), 0) << name_of(kind);
    }
  }
}

TEST(Spread, AddModeAccumulates) {
  const Cloud c = cloud(kBrick, {1.0, 0.5, 0.5}, 5);
  CellVector f, g;
  SpreadWorkspace ws;
  spread<Peskin4Kernel>(c.t, c.x, c.f, f, ws);
  spread<Peskin4Kernel>(c.t, c.x, c.f, g, ws);
  spread<Peskin4Kernel>(c.t, c.x, c.f, g, ws, SpreadMode::add);
  for (int d = 0; d < 3; ++d) {
    const double scale = *std::max_element(f[d].begin(), f[d].end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
    for (std::size_t i = 0; i < f[d].size(); ++i) ASSERT_NEAR(g[d][i], 2 * f[d][i], 1e-14 * std::abs(scale));
  }
  CellVector wrong{std::vector<double>(3), std::vector<double>(3), std::vector<double>(3)};
  EXPECT_THROW(spread<Peskin4Kernel>(c.t, c.x, c.f, wrong, ws, SpreadMode::add), std::invalid_argument);
}

// The face force carries the same total: each cell's value goes half to each face.
TEST(Spread, FaceForceKeepsTheTotal) {
  const Cloud c = cloud(kBrick, {1.0, 0.5, 0.5}, 9);
  CellVector f;
  SpreadWorkspace ws;
  spread<CosineKernel>(c.t, c.x, c.f, f, ws);
  fluid::FaceField<3> faces;
  fluid::resize<3>(faces, c.t);
  cell_to_face_force<3>(c.t, f, faces);
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);  // the sum below runs inside for_each_face
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  fluid::for_each_face<3>(c.t, [&](int d, Index, Index hi, double h, const tree::Level<3>&) {
    sum[d] += faces[d][hi] * h * h * h;
  });
  omp_set_num_threads(before);
  const Eigen::Vector3d total = c.f.rowwise().sum();
  EXPECT_LT((sum - total).norm(), 1e-13 * c.f.colwise().norm().sum());
}

// Nodes straddling a periodic side: the stencils wrap, nothing is lost.
TEST(Spread, WrapsAcrossPeriodicSides) {
  tree::TreeOptions<3> o = kBrick;
  o.periodic = {true, false, false};
  const Cloud c = cloud(o, {0.05, 0.5, 0.5}, 13);  // x from -0.25 to 0.35: unwrapped
  CellVector f;
  SpreadWorkspace ws;
  spread<CosineKernel>(c.t, c.x, c.f, f, ws);
  const auto cells = cell_totals(c.t, f, Eigen::Vector3d::Zero());
  EXPECT_LT((cells.force - c.f.rowwise().sum()).norm(), 1e-13 * c.f.colwise().norm().sum());
  // Some force landed at the far end of the brick.
  double far = 0.0;
  const auto& lv = c.t.level(c.t.max_level());
  for (Index i = lv.active_begin(); i < lv.active_end(); ++i)
    if (c.t.center(i)[0] > 1.5) far += std::abs(f[0][i]);
  EXPECT_GT(far, 0.0);
}

}  // namespace
}  // namespace capsflow::ibm
