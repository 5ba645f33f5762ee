#pragma once
// Checks every structural invariant of a forest against brute-force recomputation from
// cell coordinates (no use of the tables under test to verify themselves).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "tree/tree.hpp"
#include "tree/tree_checks.hpp"

namespace capsflow::tree::testing {

template <int D>
double domain_volume(const TreeOptions<D>& o) {
  double v = 1.0;
  for (int d = 0; d < D; ++d) v *= o.roots[d] * o.root_size;
  return v;
}

template <int D>
std::int64_t extent(const Tree<D>& t, int d, int l) {
  return static_cast<std::int64_t>(t.options().roots[d]) << l;
}

// Coordinates of the neighbour at offset o, wrapped across periodic sides; `outside` tells
// whether it lies beyond a wall.
template <int D>
Coords<D> neighbour_coords(const Tree<D>& t, int l, Coords<D> c, const Offset<D>& o, bool& outside) {
  outside = false;
  for (int d = 0; d < D; ++d) {
    const std::int64_t n = extent(t, d, l);
    std::int64_t x = c[d] + o[d];
    if (x < 0 || x >= n) {
      if (t.options().periodic[d]) x = (x + n) % n;
      else outside = true;
    }
    c[d] = static_cast<std::int32_t>(x);
  }
  return c;
}

template <int D>
void check_invariants(const Tree<D>& t) {
  const auto& opt = t.options();
  const int top = t.depth();
  // 0. The checks the checked build asserts after every change (tree_checks.hpp) agree,
  //    in every build type.
  EXPECT_EQ(topology_violation(t), "");
  EXPECT_EQ(balance_violation(t), "");
  // 1. Leaves tile the domain: their max-level Morton intervals are disjoint and their
  //    volumes add up to the brick's.
  double volume = 0.0;
  std::vector<std::pair<Key, Key>> spans;
  for (const Index c : t.leaves()) {
    const int l = t.level_of(c);
    ASSERT_TRUE(t.level(l).is_leaf(c));
    volume += std::pow(t.cell_size(l), D);
    const Key k = morton_encode<D>(t.coords(c));
    const int shift = D * (top - l);
    spans.emplace_back(k << shift, (k + 1) << shift);
  }
  EXPECT_NEAR(volume, domain_volume(opt), 1e-12 * domain_volume(opt));
  std::sort(spans.begin(), spans.end());
  for (std::size_t i = 1; i < spans.size(); ++i)
    ASSERT_LE(spans[i - 1].second, spans[i].first) << "two leaves overlap";

  for (int l = 0; l <= top; ++l) {
    const Level<D>& lv = t.level(l);
    for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
      const Coords<D> cc = t.coords(c);
      // 2. find() agrees with the index, and the parent/child links agree with keys.
      ASSERT_EQ(t.find(l, cc), c);
      if (!lv.is_leaf(c)) {
        const Index fc = lv.first_child[c - lv.base];
        const Level<D>& fine = t.level(l + 1);
        for (int b = 0; b < kChildren<D>; ++b) {
          ASSERT_LT(fc + b, fine.active_end());
          ASSERT_EQ(fine.keys[fc + b - fine.base], child_key<D>(lv.keys[c - lv.base], b));
        }
      }
      for (int s = 0; s < kStencil<D>; ++s) {
        bool outside = false;
        const Coords<D> nc = neighbour_coords<D>(t, l, cc, kOffsets<D>[s], outside);
        const Index n = lv.neighbor(c, s);
        if (outside) {
          // 3. Boundary cells sit where the offset says, and take their value from one cell inward.
          ASSERT_GE(n, lv.boundary_begin());
          ASSERT_LT(n, lv.boundary_end());
          const Index g = n - lv.boundary_begin();
          Coords<D> expect = cc;
          for (int d = 0; d < D; ++d) expect[d] += kOffsets<D>[s][d];
          for (int d = 0; d < D; ++d)
            if (opt.periodic[d]) expect[d] = nc[d];
          ASSERT_EQ(lv.boundary_coords[g], expect);
          const int side = lv.boundary_side[g];
          Coords<D> src = expect;
          src[side / 2] += (side & 1) ? -1 : 1;
          ASSERT_EQ(t.coords(lv.boundary_source[g]), src);
          continue;
        }
        // 4. Every neighbour exists at the same level, and is the cell at those coordinates.
        ASSERT_NE(n, kNone);
        ASSERT_LT(n, lv.halo_end());
        ASSERT_EQ(t.coords(n), nc);
        ASSERT_EQ(t.level_of(n), l);
        // 5. 2:1 balance: the leaf covering a leaf's neighbour is at most one level coarser.
        if (lv.is_leaf(c)) {
          const Index cover = t.locate(t.center_at(l, nc));
          ASSERT_GE(t.level_of(cover), l - 1) << "2:1 balance broken";
        }
        // 6. Symmetry among active cells.
        if (n < lv.active_end()) {
          Offset<D> back{};
          for (int d = 0; d < D; ++d) back[d] = -kOffsets<D>[s][d];
          ASSERT_EQ(lv.neighbor(n, slot_of<D>(back)), c);
        }
      }
    }
    // 7. The sibling-group rows give every face neighbour the full rows give.
    if (l >= 1) {
      ASSERT_EQ(lv.group_face.size(), static_cast<std::size_t>(lv.n_active / kChildren<D> * kFaces<D>));
      for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
        const Index group = (c - lv.base) / kChildren<D>, first = lv.base + group * kChildren<D>;
        for (int k = 0; k < kFaces<D>; ++k)
          ASSERT_EQ(group_neighbor(first, lv.group_face_row(group), static_cast<int>(c - first), k), lv.face_row(c)[k])
              << "level " << l << " cell " << c << " face " << k;
      }
      // Each group's parent has it as its children.
      ASSERT_EQ(lv.group_parent.size(), static_cast<std::size_t>(lv.n_active / kChildren<D>));
      const Level<D>& up = t.level(l - 1);
      for (Index g = 0; g < lv.n_active / kChildren<D>; ++g) {
        const Index p = lv.group_parent[g];
        ASSERT_TRUE(p >= up.active_begin() && p < up.active_end() && !up.is_leaf(p));
        ASSERT_EQ(up.first_child[p - up.base], lv.base + g * kChildren<D>);
      }
    }
    // 8. Halo cells are children of leaves.
    for (Index g = 0; g < lv.n_halo / kChildren<D>; ++g) {
      const Index p = lv.halo_parent[g];
      const Level<D>& coarse = t.level(l - 1);
      ASSERT_TRUE(coarse.is_leaf(p));
      ASSERT_EQ(coarse.first_child[p - coarse.base], lv.halo_begin() + g * kChildren<D>);
    }
  }
}

}  // namespace capsflow::tree::testing
