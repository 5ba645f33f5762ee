// Locating stencil cells on the tree, and the error that names a missing one.
#include "ibm/stencil.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "tree/partition.hpp"

namespace capsflow::ibm {

namespace {

// Levels between the anchors and the stencil level: 2^k >= W - 1 (at most 2 anchors per
// axis), and k >= 2 so that a small stencil usually sits in one anchor.
constexpr int anchor_depth(int w) {
  int k = 2;
  while ((1 << k) < w - 1) ++k;
  return k;
}

bool is_active_leaf(const tree::Tree<3>& t, int level, Index c) {
  const tree::Level<3>& lv = t.level(level);
  return c != tree::kNone && c < lv.active_end() && lv.is_leaf(c);
}

}  // namespace

int find_box(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
             Index* cells) {
  CAPSFLOW_ASSERT(n[0] >= 1 && n[1] >= 1 && n[2] >= 1 && n[0] <= kMaxBoxWidth && n[1] <= kMaxBoxWidth &&
                      n[2] <= kMaxBoxWidth,
                  "ibm: find_box: widths outside [1, kMaxBoxWidth]");
  const int k = anchor_depth(std::max({n[0], n[1], n[2]}));
  constexpr int P = kMaxBoxWidth / 2 + 1;  // parents per axis, at most
  constexpr int A = 2;                     // anchors per axis, at most (2^k >= width - 1)
  const int size = n[0] * n[1] * n[2];
  if (level > t.depth()) return 0;
  const int anchor_level = level - k;
  if (anchor_level < 0) {  // a very coarse tree: search every cell
    for (int s = 0; s < size; ++s) {
      const tree::Coords<3> ijk{first[0] + s % n[0], first[1] + (s / n[0]) % n[1], first[2] + s / (n[0] * n[1])};
      cells[s] = t.find(level, ijk);
      if (!is_active_leaf(t, level, cells[s])) return s;
    }
    return -1;
  }
  // Anchors: the level-(L-k) cells containing the stencil, at most A per axis (the shift
  // is a floor division, also for negative coordinates before a periodic wrap). The low
  // bits of a negative (to-be-wrapped) coordinate are those of the wrapped one, since a
  // periodic period is a multiple of 2^L.
  tree::Coords<3> a0{}, p0{}, np{};
  for (int d = 0; d < 3; ++d) {
    a0[d] = first[d] >> k;
    p0[d] = first[d] >> 1;
    np[d] = ((first[d] + n[d] - 1) >> 1) - p0[d] + 1;
  }
  Index anchor[A][A][A];
  for (int c = 0; c <= ((first[2] + n[2] - 1) >> k) - a0[2]; ++c)
    for (int b = 0; b <= ((first[1] + n[1] - 1) >> k) - a0[1]; ++b)
      for (int a = 0; a <= ((first[0] + n[0] - 1) >> k) - a0[0]; ++a)
        anchor[c][b][a] = t.find(anchor_level, {a0[0] + a, a0[1] + b, a0[2] + c});
  // The stencil's parents (level L-1), descended from their anchors, and their first
  // child: 8 contiguous cells, active (not halo) exactly when the parent is a parent.
  const tree::Level<3>& fine = t.level(level);
  Index first_child[P][P][P];
  for (int pz = 0; pz < np[2]; ++pz)
    for (int py = 0; py < np[1]; ++py)
      for (int px = 0; px < np[0]; ++px) {
        const tree::Coords<3> pc{p0[0] + px, p0[1] + py, p0[2] + pz};
        const int shift = k - 1;
        Index c = anchor[(pc[2] >> shift) - a0[2]][(pc[1] >> shift) - a0[1]][(pc[0] >> shift) - a0[0]];
        for (int l = anchor_level; l < level && c != tree::kNone; ++l) {
          const tree::Level<3>& lv = t.level(l);
          const Index fc = lv.first_child[c - lv.base];
          if (l == level - 1) {
            c = fc;  // the first of the 8 children of the parent
          } else {
            const int sh = level - l - 2;
            c = fc == tree::kNone ? tree::kNone
                                  : fc + (((pc[0] >> sh) & 1) | (((pc[1] >> sh) & 1) << 1) | (((pc[2] >> sh) & 1) << 2));
          }
        }
        first_child[pz][py][px] = c != tree::kNone && c < fine.active_end() ? c : tree::kNone;
      }
  // Below the max level an active cell may itself be a parent: check each.
  const bool check_leaf = level < t.max_level();
  int s = 0;
  for (int kz = 0; kz < n[2]; ++kz)
    for (int jy = 0; jy < n[1]; ++jy)
      for (int ix = 0; ix < n[0]; ++ix, ++s) {
        const tree::Coords<3> ijk{first[0] + ix, first[1] + jy, first[2] + kz};
        const Index fc = first_child[(ijk[2] >> 1) - p0[2]][(ijk[1] >> 1) - p0[1]][(ijk[0] >> 1) - p0[0]];
        if (fc == tree::kNone) return s;
        cells[s] = fc + ((ijk[0] & 1) | ((ijk[1] & 1) << 1) | ((ijk[2] & 1) << 2));
        if (check_leaf && !fine.is_leaf(cells[s])) return s;
      }
  CAPSFLOW_ASSERT(box_is_the_stencil(t, level, first, n, cells),
                  fmt::format("ibm: find_box on level {} from ({}, {}, {}) is not the stencil's cells", level, first[0],
                              first[1], first[2]));
  return -1;
}

int find_owned_box(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
                   const OwnedPositions& own, Index* cells) {
  if (own.all()) return find_box(t, level, first, n, cells);
  const int size = n[0] * n[1] * n[2];
  if (find_box(t, level, first, n, cells) < 0) {  // every cell exists here: keep the owned ones
    for (int s = 0; s < size; ++s)
      if (!t.owns(cells[s])) cells[s] = tree::kNone;
    return -1;
  }
  const auto& o = t.options();
  for (int s = 0; s < size; ++s) {
    tree::Coords<3> ijk{first[0] + s % n[0], first[1] + (s / n[0]) % n[1], first[2] + s / (n[0] * n[1])};
    for (int d = 0; d < 3; ++d) {
      const auto extent = static_cast<std::int32_t>(o.roots[d] << level);
      if (ijk[d] >= 0 && ijk[d] < extent) continue;
      if (!o.periodic[d]) return s;  // beyond a wall: no rank owns it
      ijk[d] = ((ijk[d] % extent) + extent) % extent;
    }
    cells[s] = tree::kNone;
    if (!own.contains(tree::curve_position<3>(level, tree::morton_encode<3>(ijk), o.max_level))) continue;
    const Index c = t.find(level, ijk);
    const tree::Level<3>& lv = t.level(level);
    if (c == tree::kNone || c >= lv.active_end() || !lv.is_leaf(c)) return s;
    cells[s] = c;
  }
  return -1;
}

bool box_is_the_stencil(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
                        const Index* cells) {
  const auto& o = t.options();
  const tree::Level<3>& lv = t.level(level);
  for (int s = 0; s < n[0] * n[1] * n[2]; ++s) {
    tree::Coords<3> ijk{first[0] + s % n[0], first[1] + (s / n[0]) % n[1], first[2] + s / (n[0] * n[1])};
    for (int d = 0; d < 3; ++d) {  // wrapped across periodic sides, as find_box does
      const auto m = static_cast<std::int32_t>(o.roots[d] << level);
      if (o.periodic[d]) ijk[d] = ((ijk[d] % m) + m) % m;
    }
    if (!is_active_leaf(t, level, cells[s]) || tree::morton_decode<3>(lv.keys[cells[s] - lv.base]) != ijk)
      return false;
  }
  return true;
}

void require_box(const tree::Tree<3>& t, int level, const tree::Coords<3>& first, const std::array<int, 3>& n,
                 Index* cells, std::int64_t node, const double* x, std::string_view operation,
                 std::string_view kernel, const OwnedPositions& own) {
  const int slot = find_owned_box(t, level, first, n, own, cells);
  if (slot < 0) return;
  const tree::Coords<3> ijk{first[0] + slot % n[0], first[1] + (slot / n[0]) % n[1], first[2] + slot / (n[0] * n[1])};
  throw_missing_cell(t, level, ijk, node, x, operation, kernel);
}

void throw_missing_cell(const tree::Tree<3>& t, int level, const tree::Coords<3>& ijk, std::int64_t node,
                        const double* x, std::string_view operation, std::string_view kernel) {
  const auto& o = t.options();
  StencilError::Where at{.node = node, .x = {x[0], x[1], x[2]}, .level = level};
  const std::string where =
      fmt::format("ibm: {} with the {} kernel: node {} at ({:.6g}, {:.6g}, {:.6g}) needs cell ({}, {}, {}) of level {}",
                  operation, kernel, node, x[0], x[1], x[2], ijk[0], ijk[1], ijk[2], level);
  for (int d = 0; d < 3; ++d) {
    const std::int64_t n = static_cast<std::int64_t>(o.roots[d]) << level;
    if (!o.periodic[d] && (ijk[d] < 0 || ijk[d] >= n)) {
      at.side = 2 * d + (ijk[d] < 0 ? 0 : 1);
      throw StencilError(
          fmt::format("{}, which lies outside the domain across side {}_{}: the membrane is within the kernel's "
                      "reach of that boundary (dx = {:.4g})",
                      where, "xyz"[d], ijk[d] < 0 ? "lo" : "hi", t.cell_size(level)),
          StencilError::Missing::outside_domain, at);
    }
  }
  std::string found = "the tree is not refined there";
  if (level <= t.depth()) {
    const Index c = t.find(level, ijk);
    if (c != tree::kNone && c >= t.level(level).halo_begin()) {
      at.found_level = level - 1;
      found = fmt::format("only a halo cell exists there (the leaf is of level {})", level - 1);
    } else if (c == tree::kNone) {
      tree::Coords<3> wrapped = ijk;
      for (int d = 0; d < 3; ++d) {
        const auto n = static_cast<std::int32_t>(o.roots[d] << level);
        wrapped[d] = ((wrapped[d] % n) + n) % n;
      }
      const Index leaf = t.locate(t.center_at(level, wrapped));
      at.found_level = t.level_of(leaf);
      found = fmt::format("the leaf there is of level {}", at.found_level);
    }
  }
  throw StencilError(fmt::format("{} as an active leaf, but {}: refine to level {} around the membrane first "
                                 "(the membrane's refinement band, as the adaptation's required level)",
                                 where, found, level),
                     StencilError::Missing::not_refined, at);
}

}  // namespace capsflow::ibm
