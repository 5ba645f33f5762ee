// NodeBoxes (a step's stencil boxes, found once per node): every face stencil of every
// kernel pair a coupling may use is copied out of its node's box with exactly the cells
// find_box locates; a box the tree cannot complete hands the node back to the stages' own
// search; cells outside this rank's positions are left out as find_owned_box leaves them;
// spreading and interpolating through the boxes give the same bits as without them; and on
// N ranks each node is interpolated whole by one rank, the owner of its box's centre.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "ibm/interpolate.hpp"
#include "ibm/node_boxes.hpp"
#include "ibm/spread.hpp"
#include "ibm_support.hpp"
#include "tree/partition.hpp"

namespace capsflow::ibm {
namespace {

const tree::TreeOptions<3> kBox{.roots = {2, 1, 1}, .root_size = 1.0, .origin = {0, 0, 0}, .max_level = 5};

struct Pair {
  KernelKind spread, interpolate;
  bool divergence_free;
};
const std::array kPairs{Pair{KernelKind::cosine, KernelKind::cosine, true},
                        Pair{KernelKind::cosine, KernelKind::hat, true},
                        Pair{KernelKind::peskin4, KernelKind::hat, false},
                        Pair{KernelKind::hat, KernelKind::hat, false}};

// Every face stencil of both kernels of p at every node of x, from the boxes and from
// find_owned_box: the same cells, and a box is complete iff every stencil is found.
void expect_boxes_hold_the_stencils(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Pair& p,
                                    const OwnedPositions& own, int& complete) {
  NodeBoxes boxes;
  const std::array kinds{p.spread, p.interpolate};
  boxes.find(t, x, kinds, p.divergence_free, own);
  ASSERT_EQ(boxes.nodes(), x.cols());
  const int level = t.max_level();
  const double h = t.cell_size(level);
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    bool from_box = true;
    for (const KernelKind kind : kinds)
      with_face_kernel(kind, p.divergence_free, [&]<Kernel K>(K) {
        for (int axis = 0; axis < 3; ++axis) {
          const BoxStencil st = face_stencil<K>(t.options(), h, &x(0, i), axis);
          const BoxStencil bounds = face_stencil_bounds<K>(t.options(), h, &x(0, i), axis);
          ASSERT_EQ(bounds.first, st.first);
          ASSERT_EQ(bounds.n, st.n);
          std::vector<Index> expected(static_cast<std::size_t>(st.size())), got(expected.size(), -7);
          const bool found = find_owned_box(t, level, st.first, st.n, own, expected.data()) < 0;
          const bool copied = boxes.stencil_cells(i, st, got.data());
          from_box = from_box && copied;
          if (copied) {
            ASSERT_TRUE(found) << "node " << i;
            EXPECT_EQ(got, expected) << "node " << i << " axis " << axis;
          } else {
            EXPECT_EQ(got, std::vector<Index>(expected.size(), -7)) << "an incomplete box wrote cells";
          }
        }
      });
    // A complete box serves every stencil; an incomplete one none (the stages search).
    if (from_box) ++complete;
    else EXPECT_FALSE(boxes.stencil_cells(i, face_stencil_bounds<CosineKernel>(t.options(), h, &x(0, i), 0), nullptr));
  }
}

TEST(NodeBoxes, EveryStencilOfEveryKernelPairComesOutOfItsBox) {
  const Eigen::Matrix3Xd x = test::random_ball(400, 0.2, {1.0, 0.5, 0.5}, 11);
  const tree::Tree<3> t = test::refined_around(kBox, x, 5);
  for (const Pair& p : kPairs) {
    int complete = 0;
    expect_boxes_hold_the_stencils(t, x, p, {}, complete);
    EXPECT_EQ(complete, x.cols()) << "inside the band every box is complete";
  }
}

TEST(NodeBoxes, ABoxTheTreeCannotCompleteLeavesTheNodeToTheStages) {
  // Nodes refined around with a band too narrow for the boxes, and nodes next to a wall:
  // some boxes are incomplete, and each node's stencils then come from the search.
  Eigen::Matrix3Xd x = test::random_ball(300, 0.2, {1.0, 0.5, 0.5}, 12);
  const tree::Tree<3> t = test::refined_around(kBox, x, 1);
  Eigen::Matrix3Xd near_wall(3, 2);
  near_wall << 0.01, 1.99, 0.5, 0.5, 0.5, 0.5;
  int complete = 0;
  expect_boxes_hold_the_stencils(t, x, kPairs[0], {}, complete);
  EXPECT_LT(complete, x.cols());
  const tree::Tree<3> fine = test::refined_around(kBox, near_wall, 5);
  complete = 0;
  expect_boxes_hold_the_stencils(fine, near_wall, kPairs[0], {}, complete);
  EXPECT_EQ(complete, 0) << "a box across the wall cannot be complete";
}

TEST(NodeBoxes, CellsOfOtherRanksAreLeftOutAsTheOwnedSearchLeavesThem) {
  const Eigen::Matrix3Xd x = test::random_ball(300, 0.2, {1.0, 0.5, 0.5}, 13);
  const tree::Tree<3> t = test::refined_around(kBox, x, 5);
  // This "rank" owns the first root (x < 1): the nodes straddle the split.
  const tree::Key half = tree::curve_position<3>(0, tree::morton_encode<3>({1, 0, 0}), kBox.max_level);
  const OwnedPositions own{.begin = 0, .end = half};
  for (const Pair& p : kPairs) {
    int complete = 0;
    expect_boxes_hold_the_stencils(t, x, p, own, complete);
    EXPECT_EQ(complete, x.cols());
  }
}

TEST(NodeBoxes, SpreadingAndInterpolationThroughTheBoxesAreBitIdentical) {
  const Eigen::Matrix3Xd x = test::random_ball(500, 0.2, {1.0, 0.5, 0.5}, 14);
  const Eigen::Matrix3Xd f = test::random_forces(x.cols(), 15);
  const tree::Tree<3> t = test::refined_around(kBox, x, 5);
  fluid::FaceField<3> uf;
  fluid::resize<3>(uf, t);
  for (int d = 0; d < 3; ++d)
    for (std::size_t c = 0; c < uf[d].size(); ++c) uf[d][c] = std::sin(0.37 * static_cast<double>(c) + d);
  for (const Pair& p : kPairs) {
    NodeBoxes boxes;
    const std::array kinds{p.spread, p.interpolate};
    boxes.find(t, x, kinds, p.divergence_free);
    SpreadWorkspace ws;
    fluid::FaceField<3> searched, copied;
    spread_faces(p.spread, p.divergence_free, t, x, f, searched, ws);
    spread_faces(p.spread, p.divergence_free, t, x, f, copied, ws, SpreadMode::assign, {}, &boxes);
    EXPECT_EQ(searched, copied);
    Eigen::Matrix3Xd v_searched, v_copied;
    interpolate_faces(p.interpolate, p.divergence_free, t, uf, x, v_searched);
    interpolate_faces(p.interpolate, p.divergence_free, t, uf, x, v_copied, &boxes);
    EXPECT_TRUE((v_searched.array() == v_copied.array()).all());
  }
}

TEST(NodeBoxes, EachNodeIsInterpolatedWholeByOneRankAsOneRankWould) {
  // Two "ranks" owning the first and the second root, each holding every cell (a ghost layer
  // wider than any box): for each node one of them interpolates every component whole, the
  // other nothing, and the sums are the one-rank velocities to the bit.
  const Eigen::Matrix3Xd x = test::random_ball(400, 0.2, {1.0, 0.5, 0.5}, 16);
  const tree::Tree<3> t = test::refined_around(kBox, x, 5);
  fluid::FaceField<3> uf;
  fluid::resize<3>(uf, t);
  for (int d = 0; d < 3; ++d)
    for (std::size_t c = 0; c < uf[d].size(); ++c) uf[d][c] = std::cos(0.29 * static_cast<double>(c) - d);
  const tree::Key half = tree::curve_position<3>(0, tree::morton_encode<3>({1, 0, 0}), kBox.max_level);
  const std::array<OwnedPositions, 2> ranks{OwnedPositions{.begin = 0, .end = half},
                                            OwnedPositions{.begin = half, .end = ~tree::Key{0}}};
  for (const Pair& p : kPairs) {
    Eigen::Matrix3Xd whole;
    interpolate_faces(p.interpolate, p.divergence_free, t, uf, x, whole);
    std::array<NodeBoxes, 2> boxes;
    std::array<PartialVelocities, 2> parts;
    const std::array kinds{p.spread, p.interpolate};
    for (int r = 0; r < 2; ++r) {
      boxes[r].find(t, x, kinds, p.divergence_free, ranks[r]);
      interpolate_faces_owned(p.interpolate, p.divergence_free, t, uf, x, ranks[r], parts[r], &boxes[r]);
    }
    int on_each[2] = {0, 0};
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      const bool first = boxes[0].interpolator(i) == NodeBoxes::Interpolator::here;
      ASSERT_NE(first, boxes[1].interpolator(i) == NodeBoxes::Interpolator::here) << "node " << i << ": one interpolator";
      const int r = first ? 0 : 1;
      EXPECT_EQ(boxes[1 - r].interpolator(i), NodeBoxes::Interpolator::elsewhere);
      ++on_each[r];
      for (int d = 0; d < 3; ++d) {
        const auto k = static_cast<std::size_t>(3 * i + d);
        ASSERT_EQ(parts[r].kind[k], PartialVelocities::kSum);
        EXPECT_EQ(parts[1 - r].kind[k], PartialVelocities::kNothing);
        EXPECT_EQ(parts[r].sum[k], whole(d, i)) << "node " << i << " component " << d;
      }
    }
    EXPECT_GT(on_each[0], 0);
    EXPECT_GT(on_each[1], 0) << "the nodes straddle the split";
  }
}

}  // namespace
}  // namespace capsflow::ibm
