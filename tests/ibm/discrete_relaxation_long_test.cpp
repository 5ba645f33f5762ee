// The BDF2 coupled step with an inner fluid at the viscosity ratios users may ask for (0.01
// to 100): an l = 2 shape relaxing (discrete_relaxation_support.hpp) stays bounded.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "discrete_relaxation_support.hpp"

namespace capsflow::ibm {
namespace {

// BDF2 with an inner fluid takes the transpose stress explicitly at the extrapolated velocity;
// without the band's stabilisation (fluid::NavierStokes::stabilise_band) lambda = 0.01 and
// 100 blew up within 20 steps (box of 16 radii). With it every step's mode velocities stay
// bounded and, after the start's ringing, smooth. Measured over steps 20-40: at most 0.333
// and 0.085 (units of the amplitude times G / (mu a)), even-odd parts 0.0082 and 0.0006 (at
// lambda = 100 sigma = 1 left one of 0.05 about a mean of 0.03). About a minute: ctest -L long.
TEST(DiscreteRelaxation, ExtremeViscosityRatiosStayBoundedWithBdf2) {
  for (const double lambda : {0.01, 100.0}) {
    std::vector<Eigen::Vector2d> u;
    test::run_l2_relaxation({.viscosity_ratio = lambda, .Re = 1e-3, .box = 8.0, .level = 6}, 40,
                            [&](double, const Eigen::Vector2d& v, const Eigen::Vector2d& e) {
                              ASSERT_TRUE(v.allFinite());
                              EXPECT_LT(e.norm(), 0.02) << "lambda " << lambda;
                              u.push_back(v / 0.01);
                            });
    ASSERT_EQ(u.size(), 40u);
    // The even-odd part: the alternating mean over the last 20 steps (a smooth signal's
    // cancels to its change over the window / 20).
    double largest = 0.0;
    Eigen::Vector2d alternating = Eigen::Vector2d::Zero();
    for (std::size_t k = 20; k < u.size(); ++k) {
      largest = std::max(largest, u[k].cwiseAbs().maxCoeff());
      alternating += (k % 2 ? -1.0 : 1.0) * u[k] / 20.0;
    }
    const double zigzag = alternating.cwiseAbs().maxCoeff();
    std::printf("lambda %g: mode velocities over steps 20-40 at most %.3f, even-odd part %.4f\n", lambda, largest, zigzag);
    EXPECT_LT(largest, 2.0);
    EXPECT_LT(zigzag, 0.02);
  }
}

}  // namespace
}  // namespace capsflow::ibm
