#include "tree/box_owners.hpp"

#include <algorithm>
#include <array>
#include <cstdint>

#include "tree/curve_stencil.hpp"

namespace capsflow::tree {

namespace {

// One axis's part of the box in the brick: at most two intervals (a periodic wrap).
struct Intervals {
  std::array<std::array<std::int64_t, 2>, 2> range{};
  int count = 0;
};

Intervals clip_or_wrap(std::int64_t lo, std::int64_t hi, std::int64_t extent, bool periodic) {
  Intervals out;
  if (hi < lo) return out;
  if (!periodic) {
    lo = std::max<std::int64_t>(lo, 0);
    hi = std::min(hi, extent - 1);
    if (lo <= hi) out.range[out.count++] = {lo, hi};
    return out;
  }
  if (hi - lo + 1 >= extent) {
    out.range[out.count++] = {0, extent - 1};
    return out;
  }
  const std::int64_t a = ((lo % extent) + extent) % extent, b = a + (hi - lo);
  if (b < extent) {
    out.range[out.count++] = {a, b};
  } else {
    out.range[out.count++] = {a, extent - 1};
    out.range[out.count++] = {0, b - extent};
  }
  return out;
}

template <int D>
struct Visitor {
  const Partition& partition;
  const TreeOptions<D>& options;
  int level;  // of the box's cells
  std::array<std::array<std::int64_t, 2>, D> box{};
  std::vector<int>& ranks;

  void add_owners(int first, int last) {  // the ranks first..last that own positions
    for (int r = first; r <= last; ++r)
      if (partition.split(r) < partition.split(r + 1)) ranks.push_back(r);
  }
  // The block (k, c): its cells of `level` are [c << s, ((c + 1) << s) - 1], s = level - k.
  void visit(int k, const Coords<D>& c) {
    const int s = level - k;
    bool inside = true;
    for (int d = 0; d < D; ++d) {
      const std::int64_t b0 = std::int64_t{c[d]} << s, b1 = ((std::int64_t{c[d]} + 1) << s) - 1;
      if (b1 < box[d][0] || b0 > box[d][1]) return;
      inside = inside && b0 >= box[d][0] && b1 <= box[d][1];
    }
    // A block one rank owns whole needs no descent, whatever part of it the box covers.
    const Key begin = curve_position<D>(k, morton_encode<D>(c), options.max_level);
    const int first = partition.owner(begin), last = partition.owner(begin + span_of<D>(k, options.max_level) - 1);
    if (inside || k == level || first == last) {
      add_owners(first, last);
      return;
    }
    for (int b = 0; b < (1 << D); ++b) {
      Coords<D> child{};
      for (int d = 0; d < D; ++d) child[d] = 2 * c[d] + ((b >> d) & 1);
      visit(k + 1, child);
    }
  }
};

}  // namespace

template <int D>
void box_owners(const Partition& partition, const TreeOptions<D>& options, int level, const Coords<D>& lo,
                const Coords<D>& hi, std::vector<int>& ranks) {
  const std::size_t first = ranks.size();
  std::array<Intervals, D> axis;
  for (int d = 0; d < D; ++d)
    axis[d] = clip_or_wrap(lo[d], hi[d], std::int64_t{options.roots[d]} << level, options.periodic[d]);
  int combinations = 1;
  for (int d = 0; d < D; ++d) combinations *= axis[d].count;
  Visitor<D> v{partition, options, level, {}, ranks};
  for (int n = 0; n < combinations; ++n) {  // each wrapped part of the box
    int rest = n;
    for (int d = 0; d < D; ++d) {
      v.box[d] = axis[d].range[rest % axis[d].count];
      rest /= axis[d].count;
    }
    // Morton keys grow with each coordinate, so the part's cells lie on the curve between
    // its lowest corner's first position and its highest corner's last: one owner of both
    // owns it all (most membrane nodes' boxes), with no descent.
    Coords<D> c0{}, c1{};
    for (int d = 0; d < D; ++d) {
      c0[d] = static_cast<std::int32_t>(v.box[d][0]);
      c1[d] = static_cast<std::int32_t>(v.box[d][1]);
    }
    const int low = partition.owner(curve_position<D>(level, morton_encode<D>(c0), options.max_level));
    const int high = partition.owner(curve_position<D>(level, morton_encode<D>(c1), options.max_level) +
                                     span_of<D>(level, options.max_level) - 1);
    if (low == high) {
      ranks.push_back(low);
      continue;
    }
    // The roots the part touches, then down their blocks.
    Coords<D> r0{}, r1{};
    for (int d = 0; d < D; ++d) {
      r0[d] = static_cast<std::int32_t>(v.box[d][0] >> level);
      r1[d] = static_cast<std::int32_t>(v.box[d][1] >> level);
    }
    Coords<D> root = r0;
    while (true) {
      v.visit(0, root);
      int d = 0;
      for (; d < D; ++d) {
        if (++root[d] <= r1[d]) break;
        root[d] = r0[d];
      }
      if (d == D) break;
    }
  }
  std::sort(ranks.begin() + static_cast<std::ptrdiff_t>(first), ranks.end());
  ranks.erase(std::unique(ranks.begin() + static_cast<std::ptrdiff_t>(first), ranks.end()), ranks.end());
}

template void box_owners<2>(const Partition&, const TreeOptions<2>&, int, const Coords<2>&, const Coords<2>&,
                            std::vector<int>&);
template void box_owners<3>(const Partition&, const TreeOptions<3>&, int, const Coords<3>&, const Coords<3>&,
                            std::vector<int>&);

}  // namespace capsflow::tree
