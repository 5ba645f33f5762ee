// The checks of tree_checks.hpp.
#include "tree/tree_checks.hpp"

#include <cstdint>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace capsflow::tree {

namespace {

// Coordinates of the cell at offset o from c on level l, wrapped across periodic sides;
// `outside` tells whether they lie beyond a wall.
template <int D>
Coords<D> offset_coords(const Tree<D>& t, int l, Coords<D> c, const Offset<D>& o, bool& outside) {
  outside = false;
  for (int d = 0; d < D; ++d) {
    const std::int64_t n = static_cast<std::int64_t>(t.options().roots[d]) << l;
    std::int64_t x = c[d] + o[d];
    if (x < 0 || x >= n) {
      if (t.options().periodic[d]) x = (x + n) % n;
      else outside = true;
    }
    c[d] = static_cast<std::int32_t>(x);
  }
  return c;
}

}  // namespace

template <int D>
std::string topology_violation(const Tree<D>& t) {
  constexpr int C = kChildren<D>;
  std::vector<Coords<D>> coords;  // of the level's active and halo cells, decoded once
  for (int l = 0; l <= t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    coords.resize(lv.keys.size());
    for (std::size_t i = 0; i < lv.keys.size(); ++i) coords[i] = morton_decode<D>(lv.keys[i]);
    if (lv.keys.size() != static_cast<std::size_t>(lv.n_active + lv.n_halo) ||
        lv.first_child.size() != static_cast<std::size_t>(lv.size()) ||
        lv.leaf.size() != static_cast<std::size_t>(lv.n_active))
      return fmt::format("level {}: table sizes do not match its {} active, {} halo, {} boundary cells", l,
                         lv.n_active, lv.n_halo, lv.n_boundary);
    for (Index i = 0; i < lv.n_active; ++i) {
      const Index c = lv.base + i;
      const Key key = lv.keys[i];
      if (i > 0 && !(lv.keys[i - 1] < key))
        return fmt::format("level {}: active cell {} is not in Morton order after its predecessor", l, c);
      const Index fc = lv.first_child[i];
      if (!lv.leaf[i]) {  // a parent: 2^D active children carrying its key, naming it
        const Level<D>& fine = t.level(l + 1);
        if (fc < fine.active_begin() || fc + C > fine.active_end())
          return fmt::format("level {}: parent {} has no active children", l, c);
        for (int b = 0; b < C; ++b)
          if (fine.keys[fc + b - fine.base] != child_key<D>(key, b))
            return fmt::format("level {}: child {} of parent {} has key {:#x}, not {:#x}", l, b, c,
                               fine.keys[fc + b - fine.base], child_key<D>(key, b));
        if (fine.group_parent[(fc - fine.base) / C] != c)
          return fmt::format("level {}: the children of parent {} name {} as their parent", l, c,
                             fine.group_parent[(fc - fine.base) / C]);
      } else if (fc != kNone) {  // a leaf with halo children that name it
        const Level<D>& fine = t.level(l + 1);
        if (fc < fine.halo_begin() || fc + C > fine.halo_end() ||
            fine.halo_parent[(fc - fine.halo_begin()) / C] != c)
          return fmt::format("level {}: the children of leaf {} are not halo cells naming it", l, c);
      }
      const Coords<D>& cc = coords[i];
      for (int s = 0; s < kStencil<D>; ++s) {
        bool outside = false;
        const Coords<D> want = offset_coords<D>(t, l, cc, kOffsets<D>[s], outside);
        const Index n = lv.neighbor(c, s);
        if (n < lv.base || n >= lv.boundary_end())
          return fmt::format("level {}: neighbour slot {} of cell {} is {}, not a cell of the level", l, s, c, n);
        if (outside != (n >= lv.boundary_begin()))
          return fmt::format("level {}: neighbour slot {} of cell {} ({}) is {}a boundary cell, but its place is {} the brick",
                             l, s, c, fmt::join(cc, ", "), outside ? "not " : "", outside ? "outside" : "inside");
        if (outside) continue;  // boundary coordinates: unwrapped beyond the wall, checked by the tests
        const Coords<D>& got = coords[n - lv.base];
        if (got != want)
          return fmt::format("level {}: neighbour slot {} of cell {} ({}) is at ({}), not ({})", l, s, c,
                             fmt::join(cc, ", "), fmt::join(got, ", "), fmt::join(want, ", "));
        if (s < kFaces<D> && n < lv.active_end() && lv.face_row(n)[s ^ 1] != c)
          return fmt::format("level {}: cell {} is face neighbour {} of cell {}, which is not its neighbour {}", l, n,
                             s, c, s ^ 1);
      }
    }
  }
  return {};
}

template <int D>
std::string balance_violation(const Tree<D>& t) {
  constexpr int C = kChildren<D>;
  for (int l = 0; l < t.depth(); ++l) {
    const Level<D>& lv = t.level(l);
    const Level<D>& fine = t.level(l + 1);
    for (Index i = 0; i < lv.n_active; ++i) {
      if (!lv.leaf[i]) continue;
      const Index c = lv.base + i;
      for (int s = 0; s < kStencil<D>; ++s) {
        const Index n = lv.neighbor(c, s);
        if (n >= lv.active_end() || lv.is_leaf(n)) continue;  // halo (one coarser), boundary cell, leaf
        // The children of n that touch c: bit d is 0 where n lies above c along d, 1 below.
        const Index fc = lv.first_child[n - lv.base];
        for (int b = 0; b < C; ++b) {
          bool touches = true;
          for (int d = 0; d < D; ++d) {
            const int o = kOffsets<D>[s][d];
            if (o != 0) touches = touches && child_bit(b, d) == (o < 0 ? 1 : 0);
          }
          if (touches && !fine.is_leaf(fc + b))
            return fmt::format("2:1 balance: leaf {} of level {} ({}) touches a parent of level {}", c, l,
                               fmt::join(morton_decode<D>(lv.keys[i]), ", "), l + 1);
        }
      }
    }
  }
  return {};
}

template std::string topology_violation<2>(const Tree<2>&);
template std::string topology_violation<3>(const Tree<3>&);
template std::string balance_violation<2>(const Tree<2>&);
template std::string balance_violation<3>(const Tree<3>&);

}  // namespace capsflow::tree
