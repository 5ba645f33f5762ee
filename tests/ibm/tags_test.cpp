// Membrane-driven refinement tags: the tagged set against its definition (brute force),
// and, after refine_to with the tags, every stencil cell of every node at the max level.
#include <gtest/gtest.h>

#include "ibm/refinement_tags.hpp"
#include "ibm/stencil.hpp"
#include "ibm_support.hpp"
#include "membrane/mesh.hpp"
#include "membrane/shapes.hpp"

namespace capsflow::ibm {
namespace {

template <Kernel K>
int missing_stencils(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x) {
  constexpr int W = K::kSupport;
  const int l = t.max_level();
  int missing = 0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    const auto st = node_stencil<K>(t.options(), t.cell_size(l), &x(0, i));
    Index cells[W * W * W];
    missing += find_patch<W>(t, l, {st[0].first, st[1].first, st[2].first}, cells) >= 0;
  }
  return missing;
}

// The seed's ellipsoid shape (642 nodes), off-centre, in the seed channel.
Eigen::Matrix3Xd seed_like_nodes(double scale) {
  const auto mesh = membrane::make_icosphere({.order = membrane::Order::p1, .level = 3, .radius = 0.85 * scale});
  return membrane::seed_ellipsoid(mesh.nodes, Eigen::Vector3d(0.013, -0.021, 0.034));
}

TEST(Tags, EveryStencilExistsAfterRefinement) {
  const tree::TreeOptions<3> channel{.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 5};
  const Eigen::Matrix3Xd x = seed_like_nodes(1.0);
  for (const KernelKind spread_kind : {KernelKind::cosine, KernelKind::peskin4, KernelKind::hat})
    for (const int margin : {0, 2}) {
      tree::Tree<3> t(channel);
      MembraneTags tags;
      tags.build(channel, channel.max_level, band_cells(spread_kind, KernelKind::hat, margin), x);
      t.refine_to(tags.required_level());
      const bool wide = support_of(spread_kind) == 4;
      EXPECT_EQ(wide ? missing_stencils<CosineKernel>(t, x) : 0, 0);
      EXPECT_EQ(wide ? missing_stencils<Peskin4Kernel>(t, x) : 0, 0);
      EXPECT_EQ(missing_stencils<HatKernel>(t, x), 0);
      // A band narrower than the cosine kernel's reach leaves stencils incomplete.
      if (!wide && margin == 0) {
        EXPECT_GT(missing_stencils<CosineKernel>(t, x), 0);
      }
      std::printf("%s + hat, margin %d: band %d, %lld tagged cells, %d leaves (uniform: %d)\n",
                  name_of(spread_kind).data(), margin, tags.band(), static_cast<long long>(tags.tagged_cells()),
                  t.num_leaves(), 4 << 15);
    }
}

TEST(Tags, MatchTheirDefinition) {
  const tree::TreeOptions<3> cube{.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .max_level = 5};
  const auto mesh = membrane::make_icosphere({.level = 2, .radius = 0.5});
  const Eigen::Matrix3Xd x = mesh.nodes.colwise() + Eigen::Vector3d(0.11, -0.07, 0.05);
  const int band = 3, top = cube.max_level;
  MembraneTags tags;
  tags.build(cube, top, band, x);
  const double h = 2.0 / 32;
  std::vector<tree::Coords<3>> node_cells;
  for (Eigen::Index i = 0; i < x.cols(); ++i)
    node_cells.push_back({static_cast<std::int32_t>(std::floor((x(0, i) + 1) / h)),
                          static_cast<std::int32_t>(std::floor((x(1, i) + 1) / h)),
                          static_cast<std::int32_t>(std::floor((x(2, i) + 1) / h))});
  std::int64_t count = 0;
  for (int k = 0; k < 32; ++k)
    for (int j = 0; j < 32; ++j)
      for (int i = 0; i < 32; ++i) {
        bool near = false;
        for (const auto& c : node_cells)
          near = near || (std::abs(c[0] - i) <= band && std::abs(c[1] - j) <= band && std::abs(c[2] - k) <= band);
        count += near;
        ASSERT_EQ(tags.tagged(top, {i, j, k}), near) << i << " " << j << " " << k;
        // A box query agrees, and every ancestor of a tagged cell is tagged.
        const tree::Box<3> b{{-1 + i * h, -1 + j * h, -1 + k * h}, {-1 + (i + 1) * h, -1 + (j + 1) * h, -1 + (k + 1) * h}};
        ASSERT_EQ(tags(b), near ? top : 0);
        for (int l = top - 1; l >= 0 && near; --l) {
          ASSERT_TRUE(tags.tagged(l, {i >> (top - l), j >> (top - l), k >> (top - l)}));
        }
      }
  EXPECT_EQ(count, tags.tagged_cells());
  // An ancestor is tagged only if a descendant is (spot check: a coarse cell far away).
  EXPECT_FALSE(tags.tagged(2, {0, 0, 0}));
  EXPECT_EQ(tags(tree::Box<3>{{-1, -1, -1}, {-0.5, -0.5, -0.5}}), 0);
  EXPECT_EQ(tags(tree::Box<3>{{-1, -1, -1}, {1, 1, 1}}), top);  // the root contains the membrane
}

TEST(Tags, PeriodicImagesAndEmptyMembranes) {
  const tree::TreeOptions<3> o{.roots = {2, 1, 1}, .root_size = 1.0, .periodic = {true, false, false}, .max_level = 4};
  Eigen::Matrix3Xd x(3, 1);
  x << -0.01, 0.5, 0.5;  // unwrapped: just below x = 0, i.e. at the far end of the brick
  MembraneTags tags;
  tags.build(o, 4, 1, x);
  EXPECT_TRUE(tags.tagged(4, {31, 8, 8}));  // the node's own cell, wrapped
  EXPECT_TRUE(tags.tagged(4, {0, 8, 8}));   // and its neighbour across the periodic side
  EXPECT_FALSE(tags.tagged(4, {2, 8, 8}));
  tree::Tree<3> t(o);
  t.refine_to(tags.required_level());
  EXPECT_EQ(missing_stencils<HatKernel>(t, x), 0);
  tags.build(o, 4, 1, Eigen::Matrix3Xd(3, 0));
  EXPECT_EQ(tags(tree::Box<3>{{0, 0, 0}, {1, 1, 1}}), 0);
  EXPECT_THROW(tags.build(o, 5, 1, x), std::invalid_argument);
  EXPECT_THROW(tags.build(o, 4, -1, x), std::invalid_argument);
}

}  // namespace
}  // namespace capsflow::ibm
