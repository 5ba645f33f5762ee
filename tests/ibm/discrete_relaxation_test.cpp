// The discrete l = 2 relaxation against the small-deformation theory: the P2 membrane's
// strain energy of the two displacement modes (discrete_relaxation_support.hpp) is the
// theory's x^T K x / 2.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "discrete_relaxation_support.hpp"

namespace capsflow::ibm {
namespace {

// The P2 membrane's strain energy of each mode against x^T K x / 2, K = (4 pi / 5)
// [[4 kappa, -12 kappa], [-12 kappa, 12 (3 kappa + 2)]] G (tools/small_deformation_derivation.py):
// measured within 0.14% (642 nodes) and 0.11% (2562).
TEST(DiscreteRelaxation, TheMembranesEnergyIsTheTheorys) {
  for (const int level : {3, 4}) {
    membrane::MembraneModel model(membrane::make_icosphere({.order = membrane::Order::p2, .level = level, .radius = 1.0}),
                                  {.kind = membrane::LawKind::neo_hookean, .gs = 1.0});
    const Eigen::Matrix3Xd& x0 = model.mesh().nodes;
    const double eps = 1e-3;
    auto energy = [&](double a0, double a1) {
      Eigen::Matrix3Xd x = x0;
      for (Eigen::Index i = 0; i < x.cols(); ++i) {
        const auto [radial, tangential] = test::l2_modes(x0.col(i).normalized());
        x.col(i) += eps * (a0 * radial + a1 * tangential);
      }
      return model.energy(x);
    };
    const double e0 = energy(1, 0), e1 = energy(0, 1), e01 = energy(1, 1);
    const Eigen::Matrix2d k{{2 * e0, e01 - e0 - e1}, {e01 - e0 - e1, 2 * e1}};
    const Eigen::Matrix2d theory = 4 * std::numbers::pi / 5 * Eigen::Matrix2d{{12.0, -36.0}, {-36.0, 132.0}};
    std::printf("%ld nodes: K [%.4f %.4f; %.4f] against [%.4f %.4f; %.4f]\n", static_cast<long>(x0.cols()),
                k(0, 0) / (eps * eps), k(0, 1) / (eps * eps), k(1, 1) / (eps * eps), theory(0, 0), theory(0, 1), theory(1, 1));
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) EXPECT_NEAR(k(i, j) / (eps * eps), theory(i, j), 3e-3 * std::abs(theory(i, j)));
  }
}

}  // namespace
}  // namespace capsflow::ibm
