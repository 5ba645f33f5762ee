// Interpolation: linear fields (exact for hat and Peskin, and for the cosine kernel where
// its first moment vanishes), spreading followed by interpolation against the kernels'
// sums of squared weights, and the error for missing stencil cells.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ibm/interpolate.hpp"
#include "ibm/spread.hpp"
#include "ibm/stencil.hpp"
#include "ibm_support.hpp"

namespace capsflow::ibm {
namespace {

const tree::TreeOptions<3> kCube{.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .max_level = 5};

const Eigen::Vector3d kA(0.3, -1.2, 0.7);
const Eigen::Matrix3d kB = (Eigen::Matrix3d() << 1.5, -0.4, 2.0, 0.3, 0.9, -1.1, -2.2, 0.6, 0.25).finished();

// u = A + B x on every active cell of the max level.
CellVector linear_field(const tree::Tree<3>& t) {
  CellVector u;
  for (auto& ud : u) ud.assign(t.num_cells(), 0.0);
  const auto& lv = t.level(t.max_level());
  for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
    const auto p = t.center(c);
    const Eigen::Vector3d v = kA + kB * Eigen::Vector3d(p[0], p[1], p[2]);
    for (int d = 0; d < 3; ++d) u[d][c] = v[d];
  }
  return u;
}

std::array<std::span<const double>, 3> spans(const CellVector& u) { return {u[0], u[1], u[2]}; }

template <Kernel K>
double linear_error(const tree::Tree<3>& t, const CellVector& u, const Eigen::Matrix3Xd& x, bool cosine_shift) {
  Eigen::Matrix3Xd v;
  interpolate<K>(t, spans(u), x, v);
  const double h = t.cell_size(t.max_level());
  double worst = 0.0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    Eigen::Vector3d xi = x.col(i);
    if (cosine_shift) {  // the cosine kernel samples the field at X + dx m(r)
      const Eigen::Vector3d r = test::offsets(t, xi);
      for (int d = 0; d < 3; ++d) xi[d] += h * test::cosine_first_moment(r[d]);
    }
    worst = std::max(worst, (v.col(i) - (kA + kB * xi)).cwiseAbs().maxCoeff());
  }
  return worst;
}

TEST(Interpolate, LinearFieldsExact) {
  const Eigen::Matrix3Xd x = test::random_ball(800, 0.6, Eigen::Vector3d(0.02, -0.03, 0.01), 21);
  const tree::Tree<3> t = test::refined_around(kCube, x, 2);
  const CellVector u = linear_field(t);
  const double hat = linear_error<HatKernel>(t, u, x, false);
  const double peskin = linear_error<Peskin4Kernel>(t, u, x, false);
  const double cosine = linear_error<CosineKernel>(t, u, x, true);
  std::printf("linear field: max error hat %.2e, peskin4 %.2e, cosine (at X + dx m) %.2e\n", hat, peskin, cosine);
  EXPECT_LT(hat, 1e-14);
  EXPECT_LT(peskin, 1e-14);
  EXPECT_LT(cosine, 1e-14);
  // Without the shift the cosine kernel is not exact: its first moment is visible.
  EXPECT_GT(linear_error<CosineKernel>(t, u, x, false), 1e-4);
}

TEST(Interpolate, CosineExactWhereItsFirstMomentVanishes) {
  Eigen::Matrix3Xd x = test::random_ball(400, 0.6, Eigen::Vector3d::Zero(), 22);
  const tree::Tree<3> t = test::refined_around(kCube, x, 2);
  const double h = t.cell_size(t.max_level());
  for (Eigen::Index i = 0; i < x.cols(); ++i)  // on cell centres or faces: r = 0 or 1/2
    for (int d = 0; d < 3; ++d) x(d, i) = 0.5 * h * std::round(x(d, i) / (0.5 * h));
  EXPECT_LT(linear_error<CosineKernel>(t, linear_field(t), x, false), 1e-14);
}

// One point force F spread and interpolated back with kernel K gives, for each separate
// node, F / dx^3 prod_d S2(r_d) with S2 = sum_k w_k^2: 3/8 for cosine and Peskin whatever
// r, (1 - r)^2 + r^2 for hat.
template <Kernel K>
void check_moments(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Vector3d& force) {
  const double h = t.cell_size(t.max_level());
  Eigen::Matrix3Xd f = force.replicate(1, x.cols());
  CellVector cells;
  SpreadWorkspace ws;
  spread<K>(t, x, f, cells, ws);
  Eigen::Matrix3Xd v;
  interpolate<K>(t, spans(cells), x, v);
  double worst = 0.0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    const Eigen::Vector3d r = test::offsets(t, x.col(i));
    double s2 = 1.0;
    for (int d = 0; d < 3; ++d)
      s2 *= std::is_same_v<K, HatKernel> ? (1 - r[d]) * (1 - r[d]) + r[d] * r[d] : 0.375;
    worst = std::max(worst, (v.col(i) * h * h * h - s2 * force).norm() / force.norm());
  }
  std::printf("%-8s spread + interpolate vs kernel moments: max relative error %.2e\n", K::kName.data(), worst);
  EXPECT_LT(worst, 1e-14) << K::kName;
}

TEST(Interpolate, SpreadThenInterpolateMatchesSumOfSquares) {
  // Nodes on a lattice 6 cells apart (stencils do not overlap), with random sub-cell offsets.
  const double h = 2.0 / 32;
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> jitter(0.0, h);
  Eigen::Matrix3Xd x(3, 27);
  int n = 0;
  for (int k = -1; k <= 1; ++k)
    for (int j = -1; j <= 1; ++j)
      for (int i = -1; i <= 1; ++i) x.col(n++) = Eigen::Vector3d(i * 6 * h + jitter(gen), j * 6 * h + jitter(gen), k * 6 * h + jitter(gen));
  const tree::Tree<3> t = test::refined_around(kCube, x, 3);
  const Eigen::Vector3d force(0.4, -1.3, 2.2);
  check_moments<CosineKernel>(t, x, force);
  check_moments<HatKernel>(t, x, force);
  check_moments<Peskin4Kernel>(t, x, force);
}

TEST(Interpolate, MissingCellsThrowClearly) {
  const Eigen::Matrix3Xd inside = test::random_ball(200, 0.2, Eigen::Vector3d::Zero(), 3);
  const tree::Tree<3> t = test::refined_around(kCube, inside, 2, 2);
  Eigen::Matrix3Xd x = inside;
  x.col(57) = Eigen::Vector3d(0.6, 0.1, -0.2);  // in the level-3 grading around the band
  const CellVector u = linear_field(t);
  Eigen::Matrix3Xd v;
  const auto message = [&](auto&& call) {
    try {
      call();
    } catch (const StencilError& e) {
      EXPECT_EQ(e.node(), 57);
      return std::string(e.what());
    }
    ADD_FAILURE() << "no StencilError";
    return std::string();
  };
  using ::testing::HasSubstr;
  const std::string interp = message([&] { interpolate<HatKernel>(t, spans(u), x, v); });
  EXPECT_THAT(interp, HasSubstr("interpolation with the hat kernel: node 57 at (0.6, 0.1, -0.2)"));
  EXPECT_THAT(interp, HasSubstr("the leaf there is of level 3"));
  EXPECT_THAT(interp, HasSubstr("refine to level 5 around the membrane"));
  CellVector f;
  SpreadWorkspace ws;
  const std::string spr = message([&] { spread<CosineKernel>(t, x, x, f, ws); });
  EXPECT_THAT(spr, HasSubstr("spreading with the cosine kernel: node 57"));
  std::printf("%s\n", spr.c_str());

  // Next to a wall: the stencil leaves the domain.
  Eigen::Matrix3Xd wall = inside;
  wall.col(3) = Eigen::Vector3d(0.0, 0.0, -0.99);
  const tree::Tree<3> tw = test::refined_around(kCube, wall, 2, 2);
  const std::string side = message([&] {
    Eigen::Matrix3Xd w = wall;
    w.col(3).swap(w.col(57));
    spread<Peskin4Kernel>(tw, w, w, f, ws);
  });
  EXPECT_THAT(side, HasSubstr("outside the domain across side z_lo"));
  std::printf("%s\n", side.c_str());

  // Just beyond the refined band (a halo cell or a coarser leaf): no silent weight either.
  Eigen::Matrix3Xd jump = inside;
  jump.col(57) = Eigen::Vector3d(0.2 + 2.0 / 32 * 2.6, 0.0, 0.0);
  EXPECT_THROW(interpolate<Peskin4Kernel>(t, spans(u), jump, v), StencilError);
}

}  // namespace
}  // namespace capsflow::ibm
