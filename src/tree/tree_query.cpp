// Geometry of cells and point location.
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "tree/tree.hpp"

namespace capsflow::tree {

template <int D>
int Tree<D>::level_of(Index c) const {
  for (int l = 0; l <= depth_; ++l)
    if (c < levels_[l].base + levels_[l].size()) return l;
  throw std::out_of_range(fmt::format("tree: cell index {} is not in the tree", c));
}

template <int D>
Coords<D> Tree<D>::coords(Index c) const {
  const Level<D>& lv = levels_[level_of(c)];
  const Index local = c - lv.base;
  if (local < lv.n_active + lv.n_halo) return morton_decode<D>(lv.keys[local]);
  return lv.boundary_coords[local - lv.n_active - lv.n_halo];
}

template <int D>
Point<D> Tree<D>::center_at(int l, const Coords<D>& ijk) const {
  Point<D> x{};
  for (int d = 0; d < D; ++d) x[d] = options_.origin[d] + (ijk[d] + 0.5) * cell_size_[l];
  return x;
}

template <int D>
Point<D> Tree<D>::center(Index c) const {
  return center_at(level_of(c), coords(c));
}

template <int D>
Box<D> Tree<D>::box(Index c) const {
  const int l = level_of(c);
  const Coords<D> ijk = coords(c);
  Box<D> b;
  for (int d = 0; d < D; ++d) {
    b.lo[d] = options_.origin[d] + ijk[d] * cell_size_[l];
    b.hi[d] = b.lo[d] + cell_size_[l];
  }
  return b;
}

template <int D>
Index Tree<D>::find(int l, Coords<D> ijk) const {
  if (l < 0 || l > depth_) return kNone;
  for (int d = 0; d < D; ++d) {
    const std::int64_t n = static_cast<std::int64_t>(options_.roots[d]) << l;
    if (ijk[d] >= 0 && ijk[d] < n) continue;
    if (!options_.periodic[d]) return kNone;
    ijk[d] = static_cast<std::int32_t>(((ijk[d] % n) + n) % n);
  }
  std::int64_t r = 0;
  for (int d = D - 1; d >= 0; --d) r = r * options_.roots[d] + (ijk[d] >> l);
  Index c = root_index_[r];
  for (int k = 0; k < l; ++k) {
    const Level<D>& lv = levels_[k];
    const Index fc = lv.first_child[c - lv.base];
    if (fc == kNone) return kNone;
    int child = 0;
    for (int d = 0; d < D; ++d) child |= ((ijk[d] >> (l - k - 1)) & 1) << d;
    c = fc + child;
  }
  CAPSFLOW_ASSERT(c < levels_[l].halo_end() && level_of(c) == l && coords(c) == ijk,
                  fmt::format("tree: find({}, ({})) descended to cell {}, which is not that cell", l,
                              fmt::join(ijk, ", "), c));
  return c;
}

template <int D>
bool Tree<D>::contains(Index c, const Point<D>& x) const {
  // Rounding of (x - origin) / h can put a point within a few ulps of a face in the
  // cell on either side: allow that much.
  const Box<D> b = box(c);
  for (int d = 0; d < D; ++d) {
    const double slack = 1e-12 * (std::abs(x[d]) + options_.roots[d] * options_.root_size);
    if (!(x[d] >= b.lo[d] - slack && x[d] <= b.hi[d] + slack)) return false;
  }
  return true;
}

template <int D>
Index Tree<D>::locate(const Point<D>& x) const {
  const int top = options_.max_level;
  const double h = cell_size_[top];
  Coords<D> ijk{};
  for (int d = 0; d < D; ++d) {
    const double lo = options_.origin[d];
    const double hi = lo + options_.roots[d] * options_.root_size;
    if (!(x[d] >= lo && x[d] <= hi))
      throw std::out_of_range(fmt::format("tree: point ({}) is outside the domain along {}: [{}, {}]",
                                          fmt::join(x, ", "), "xyz"[d], lo, hi));
    const std::int64_t n = static_cast<std::int64_t>(options_.roots[d]) << top;
    const auto i = static_cast<std::int64_t>(std::floor((x[d] - lo) / h));
    ijk[d] = static_cast<std::int32_t>(std::clamp<std::int64_t>(i, 0, n - 1));
  }
  std::int64_t r = 0;
  for (int d = D - 1; d >= 0; --d) r = r * options_.roots[d] + (ijk[d] >> top);
  Index c = root_index_[r];
  for (int k = 0;; ++k) {
    const Level<D>& lv = levels_[k];
    if (lv.leaf[c - lv.base]) {
      CAPSFLOW_ASSERT(contains(c, x), fmt::format("tree: locate({}) returned leaf {}, which does not contain it",
                                                  fmt::join(x, ", "), c));
      return c;
    }
    int child = 0;
    for (int d = 0; d < D; ++d) child |= ((ijk[d] >> (top - k - 1)) & 1) << d;
    c = lv.first_child[c - lv.base] + child;
  }
}

template <int D>
void Tree<D>::cells_around(const Point<D>& x, int l, int width, std::vector<Index>& out) const {
  if (width < 2 || width % 2 != 0)
    throw std::invalid_argument(fmt::format("tree: cells_around width must be even and >= 2, got {}", width));
  const double h = cell_size_.at(l);
  Coords<D> lo{};
  for (int d = 0; d < D; ++d)
    lo[d] = static_cast<std::int32_t>(std::floor((x[d] - options_.origin[d]) / h - 0.5)) - (width / 2 - 1);
  int total = 1;
  for (int d = 0; d < D; ++d) total *= width;
  out.resize(total);
  for (int n = 0; n < total; ++n) {
    Coords<D> ijk = lo;
    for (int d = 0, r = n; d < D; ++d, r /= width) ijk[d] += r % width;
    out[n] = find(l, ijk);
  }
}

template int Tree<2>::level_of(Index) const;
template Coords<2> Tree<2>::coords(Index) const;
template Point<2> Tree<2>::center_at(int, const Coords<2>&) const;
template Point<2> Tree<2>::center(Index) const;
template Box<2> Tree<2>::box(Index) const;
template Index Tree<2>::find(int, Coords<2>) const;
template bool Tree<2>::contains(Index, const Point<2>&) const;
template Index Tree<2>::locate(const Point<2>&) const;
template void Tree<2>::cells_around(const Point<2>&, int, int, std::vector<Index>&) const;
template int Tree<3>::level_of(Index) const;
template Coords<3> Tree<3>::coords(Index) const;
template Point<3> Tree<3>::center_at(int, const Coords<3>&) const;
template Point<3> Tree<3>::center(Index) const;
template Box<3> Tree<3>::box(Index) const;
template Index Tree<3>::find(int, Coords<3>) const;
template bool Tree<3>::contains(Index, const Point<3>&) const;
template Index Tree<3>::locate(const Point<3>&) const;
template void Tree<3>::cells_around(const Point<3>&, int, int, std::vector<Index>&) const;

}  // namespace capsflow::tree
