// Morton keys and stencil tables: exhaustive identities at low levels.
#include <gtest/gtest.h>

#include <set>

#include "tree/morton.hpp"
#include "tree/stencil.hpp"

namespace capsflow::tree {
namespace {

TEST(Morton, RoundTrip2DExhaustive) {
  std::set<Key> seen;
  for (int i = 0; i < 256; ++i)
    for (int j = 0; j < 256; ++j) {
      const Key k = morton_encode<2>({i, j});
      EXPECT_EQ(morton_decode<2>(k), (Coords<2>{i, j}));
      seen.insert(k);
    }
  // A bijection onto [0, 256^2): Morton order of a square is a permutation of its cells.
  EXPECT_EQ(seen.size(), 256u * 256u);
  EXPECT_EQ(*seen.rbegin(), 256u * 256u - 1);
}

TEST(Morton, RoundTrip3DExhaustive) {
  std::set<Key> seen;
  for (int i = 0; i < 32; ++i)
    for (int j = 0; j < 32; ++j)
      for (int k = 0; k < 32; ++k) {
        const Key key = morton_encode<3>({i, j, k});
        ASSERT_EQ(morton_decode<3>(key), (Coords<3>{i, j, k}));
        seen.insert(key);
      }
  EXPECT_EQ(seen.size(), 32768u);
  EXPECT_EQ(*seen.rbegin(), 32767u);
}

TEST(Morton, ExtremeCoordinatesRoundTrip) {
  const std::int32_t top3 = (1 << 21) - 1;
  EXPECT_EQ(morton_decode<3>(morton_encode<3>({top3, 0, top3})), (Coords<3>{top3, 0, top3}));
  const std::int32_t top2 = 0x7fffffff;
  EXPECT_EQ(morton_decode<2>(morton_encode<2>({top2, 12345})), (Coords<2>{top2, 12345}));
}

template <int D>
void check_parent_child(int side) {
  int total = 1;
  for (int d = 0; d < D; ++d) total *= side;
  for (int n = 0; n < total; ++n) {
    Coords<D> c{};
    for (int d = 0, r = n; d < D; ++d, r /= side) c[d] = r % side;
    const Key k = morton_encode<D>(c);
    for (int b = 0; b < kChildren<D>; ++b) {
      const Key ck = child_key<D>(k, b);
      const Coords<D> cc = morton_decode<D>(ck);
      for (int d = 0; d < D; ++d) ASSERT_EQ(cc[d], 2 * c[d] + child_bit(b, d));
      ASSERT_EQ(parent_key<D>(ck), k);
      ASSERT_EQ(child_number<D>(ck), b);
    }
  }
}

TEST(Morton, ParentChildIdentities) {
  check_parent_child<2>(64);
  check_parent_child<3>(16);
}

template <int D>
void check_stencil() {
  std::set<Offset<D>> seen;
  for (int s = 0; s < kStencil<D>; ++s) {
    const Offset<D>& o = kOffsets<D>[s];
    EXPECT_TRUE(seen.insert(o).second);
    EXPECT_EQ(slot_of<D>(o), s);
    Offset<D> opposite{};
    for (int d = 0; d < D; ++d) opposite[d] = -o[d];
    EXPECT_GE(slot_of<D>(opposite), 0);
  }
  EXPECT_EQ(slot_of<D>(Offset<D>{}), -1);
  for (int d = 0; d < D; ++d)
    for (int side = 0; side < 2; ++side) {
      Offset<D> o{};
      o[d] = side ? 1 : -1;
      EXPECT_EQ(slot_of<D>(o), face_slot(d, side));
    }
}

TEST(Stencil, SlotsCoverTheBlockOnceWithFacesFirst) {
  check_stencil<2>();
  check_stencil<3>();
  EXPECT_EQ(kStencil<3>, 26);
  EXPECT_EQ(kStencil<2>, 8);
}

// The neighbour at offset o of cell c is the child (of the parent's neighbour at
// floor((bit + o) / 2)) numbered by (bit + o) mod 2: the rule the top-down build relies on.
TEST(Morton, NeighbourOfChildIsChildOfParentNeighbour) {
  for (int i = 1; i < 30; ++i)
    for (int j = 1; j < 30; ++j)
      for (int s = 0; s < kStencil<2>; ++s) {
        const Offset<2>& o = kOffsets<2>[s];
        const Coords<2> c{i, j}, n{i + o[0], j + o[1]};
        const Coords<2> p{c[0] >> 1, c[1] >> 1};
        Coords<2> pn{};
        int child = 0;
        for (int d = 0; d < 2; ++d) {
          const int t = (c[d] & 1) + o[d];
          pn[d] = p[d] + (t < 0 ? -1 : t / 2);
          child |= ((t + 2) & 1) << d;
        }
        EXPECT_EQ(child_key<2>(morton_encode<2>(pn), child), morton_encode<2>(n));
      }
}

}  // namespace
}  // namespace capsflow::tree
