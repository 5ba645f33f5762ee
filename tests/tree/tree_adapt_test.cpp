// The wavelet criterion and forced refinement.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "tree_invariants.hpp"

namespace capsflow::tree {
namespace {

double front(const Point<2>& x) {  // a sharp circular front of radius 0.3 and width 0.005
  return std::tanh((std::hypot(x[0] - 0.5, x[1] - 0.5) - 0.3) / 0.005);
}

TEST(Wavelet, RefinesAtASharpFeatureOnly) {
  Tree<2> t({.roots = {1, 1}, .max_level = 9});
  t.refine_to([](const Box<2>&) { return 4; });
  const FieldId f = t.add_field({.name = "front"});
  auto reset = [&] { for (const Index c : t.leaves()) t.values(f)[c] = front(t.center(c)); };
  reset();
  for (int pass = 0; pass < 12; ++pass) {
    (void)t.adapt({.criteria = {{f, 1e-2}}, .min_level = 3});
    reset();  // re-sample the exact field on the new leaves
  }
  testing::check_invariants(t);
  EXPECT_EQ(t.depth(), 9);
  // The finest leaves hug the front; far from it the mesh is coarse.
  for (const Index c : t.leaves()) {
    const Point<2> x = t.center(c);
    const double dist = std::abs(std::hypot(x[0] - 0.5, x[1] - 0.5) - 0.3);
    const int l = t.level_of(c);
    if (l == 9) {
      EXPECT_LT(dist, 0.06);
    }
    if (dist > 0.2) {
      EXPECT_LE(l, 5);
    }
  }
  // Every point of the front lies in a leaf of the finest two levels (the 1.5 hysteresis
  // lets a cell whose detail is between tol/1.5 and tol sit one level up), most at the finest.
  int finest = 0;
  for (int k = 0; k < 360; ++k) {
    const double a = k * M_PI / 180.0;
    const int l = t.level_of(t.locate({0.5 + 0.3 * std::cos(a), 0.5 + 0.3 * std::sin(a)}));
    EXPECT_GE(l, 8);
    finest += l == 9;
  }
  EXPECT_GT(finest, 300);
  EXPECT_LT(t.num_leaves(), (1 << 18) / 10) << "far fewer leaves than the uniform grid";
}

// Masked cells (those inside embedded solids) neither refine for their wavelets nor keep
// their level: the front's right half is masked and ends as coarse as the far field.
TEST(Wavelet, MaskedCellsFollowNoCriterion) {
  Tree<2> t({.roots = {1, 1}, .max_level = 7});
  t.refine_to([](const Box<2>&) { return 4; });
  const FieldId f = t.add_field({.name = "front"});
  std::vector<std::uint8_t> mask;
  auto reset = [&] {
    for (const Index c : t.leaves()) t.values(f)[c] = front(t.center(c));
    mask.assign(static_cast<std::size_t>(t.num_cells()), 1);
    for (Index c = 0; c < t.num_cells(); ++c)
      if (t.box(c).lo[0] >= 0.5) mask[static_cast<std::size_t>(c)] = 0;
  };
  reset();
  for (int pass = 0; pass < 8; ++pass) {
    (void)t.adapt({.criteria = {{f, 1e-2}}, .min_level = 3, .criteria_mask = mask});
    reset();
  }
  testing::check_invariants(t);
  int fine_left = 0;
  for (const Index c : t.leaves()) {
    const int l = t.level_of(c);
    if (t.box(c).lo[0] >= 0.75) {
      EXPECT_LE(l, 4) << "a masked leaf away from the unmasked half";  // 2:1 grading from x = 0.5
    }
    fine_left += l == 7 && t.box(c).hi[0] <= 0.5;
  }
  EXPECT_GT(fine_left, 0) << "the unmasked half of the front is refined";
  EXPECT_THROW((void)t.adapt({.criteria = {{f, 1e-2}}, .criteria_mask = std::vector<std::uint8_t>(3, 1)}), std::invalid_argument);
}

TEST(Wavelet, CoarsensAConstantField) {
  Tree<3> t({.roots = {2, 1, 1}, .max_level = 4});
  t.refine_to([](const Box<3>&) { return 4; });
  const FieldId f = t.add_field({.name = "c"});
  for (const Index c : t.leaves()) t.values(f)[c] = 2.5;
  for (int pass = 0; pass < 4; ++pass) (void)t.adapt({.criteria = {{f, 1e-6}}, .min_level = 1});
  EXPECT_EQ(t.depth(), 1);
  EXPECT_EQ(t.num_leaves(), 2 * 8);
  for (const Index c : t.leaves()) EXPECT_DOUBLE_EQ(t.values(f)[c], 2.5);
}

TEST(Wavelet, ErrorIsZeroForLinearFields) {
  Tree<2> t({.roots = {1, 1}, .max_level = 6});
  t.refine_to([](const Box<2>& b) { return b.lo[0] < 0.3 ? 6 : 3; });
  BoundaryConditions<2> bc;
  for (auto& s : bc.side) {
    s.kind = BcKind::dirichlet;
    s.function = [](const Point<2>& x) { return 2 * x[0] - 3 * x[1]; };
  }
  const FieldId f = t.add_field({.name = "lin", .bc = bc});
  for (const Index c : t.leaves()) t.values(f)[c] = 2 * t.center(c)[0] - 3 * t.center(c)[1];
  t.sync(f);
  std::vector<float> err;
  const WaveletTolerance crit{f, 1.0};
  t.wavelet_error({&crit, 1}, err);
  for (const float e : err) EXPECT_LT(e, 1e-10f);
}

TEST(ForcedRefinement, ReachesTheRequiredLevelAndLetsGo) {
  Tree<3> t({.roots = {4, 1, 1}, .root_size = 2, .origin = {-4, -1, -1}, .max_level = 5});
  auto near_origin = [](const Box<3>& b) {
    double d2 = 0;
    for (int d = 0; d < 3; ++d) {
      const double c = std::clamp(0.0, b.lo[d], b.hi[d]);
      d2 += c * c;
    }
    return d2 < 0.1 * 0.1 ? 5 : 0;
  };
  t.refine_to(near_origin);
  testing::check_invariants(t);
  EXPECT_EQ(t.level_of(t.locate({0.05, 0.0, 0.0})), 5);
  EXPECT_LE(t.level_of(t.locate({3.5, 0.5, 0.5})), 2);
  // Without the demand and with no criterion, repeated adapts coarsen back to the roots.
  for (int pass = 0; pass < 6; ++pass) (void)t.adapt({});
  EXPECT_EQ(t.depth(), 0);
  EXPECT_EQ(t.num_leaves(), 4);
}

}  // namespace
}  // namespace capsflow::tree
