#pragma once
// Cells named by their place on the Morton curve, and the cells around one: the vocabulary
// of the ghost plan (distributed_forest.hpp), which asks other ranks about cells they do not
// hold, and of leaf migration.
#include <cstdint>
#include <vector>

#include "tree/morton.hpp"
#include "tree/partition.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::tree {

// A cell on the curve: its position and level (a parent shares its first child's position).
struct CurveCell {
  Key position = 0;
  int level = 0;
  bool operator==(const CurveCell&) const = default;
};

// Curve order: by position, a parent before its first child.
inline bool curve_less(const CurveCell& a, const CurveCell& b) {
  return a.position != b.position ? a.position < b.position : a.level < b.level;
}

// The curve positions a cell of level l covers: [position, position + span).
template <int D>
Key span_of(int level, int max_level) {
  return Key{1} << (D * (max_level - level));
}

// The Morton key of a cell from its curve position.
template <int D>
Key key_of(const CurveCell& c, int max_level) {
  return c.position >> (D * (max_level - c.level));
}

// Calls f(CurveCell) for the cells of level m within `width` cells of the cell at coords c
// (wrapped across periodic sides, none beyond a wall), the cell itself excluded.
template <int D, class F>
void for_each_stencil_cell(const TreeOptions<D>& o, int m, const Coords<D>& c, int width, F&& f) {
  const int side = 2 * width + 1;
  int count = 1;
  for (int d = 0; d < D; ++d) count *= side;
  for (int n = 0; n < count; ++n) {
    Coords<D> x{};
    bool inside = true, self = true;
    for (int d = 0, rest = n; d < D; ++d, rest /= side) {
      const int offset = rest % side - width;
      self = self && offset == 0;
      const std::int64_t extent = static_cast<std::int64_t>(o.roots[d]) << m;
      std::int64_t v = c[d] + offset;
      if (v < 0 || v >= extent) {
        if (!o.periodic[d]) inside = false;
        v = ((v % extent) + extent) % extent;
      }
      x[d] = static_cast<std::int32_t>(v);
    }
    if (inside && !self) f(CurveCell{curve_position<D>(m, morton_encode<D>(x), o.max_level), m});
  }
}

template <int D>
void stencil_cells(const TreeOptions<D>& o, int m, const Coords<D>& c, int width, std::vector<CurveCell>& out) {
  for_each_stencil_cell<D>(o, m, c, width, [&](const CurveCell& cell) { out.push_back(cell); });
}

}  // namespace capsflow::tree
