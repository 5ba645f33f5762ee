// Long validations (ctest -L long; not in the default suite): the cavity at Re = 1000.
#include <gtest/gtest.h>

#include <cstdio>

#include "cavity.hpp"

namespace capsflow::fluid {
namespace {

// Adaptive tree up to 128^2 resolution, steady state by t = 60 (about 9000 steps).
TEST(CavityLong, Re1000AdaptiveMatchesGhia) {
  tree::Tree<2> t({.roots = {1, 1}, .max_level = 7});
  t.refine_to([](const tree::Box<2>&) { return 5; });
  const auto r = testing::run_cavity(t, 1000, 60.0, 1e-4, 0.002);
  std::printf("adaptive cavity Re 1000: %d leaves, u %.4f v %.4f, t %.1f\n", r.leaves, r.u_error, r.v_error, r.t);
  EXPECT_LE(r.u_error, 0.02);
  EXPECT_LE(r.v_error, 0.02);
  EXPECT_LT(r.leaves, 128 * 128 / 2);
}

}  // namespace
}  // namespace capsflow::fluid
