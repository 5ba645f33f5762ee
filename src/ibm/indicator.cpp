#include "ibm/indicator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <optional>
#include <utility>

#include "geometry/axis_crossings.hpp"
#include "tree/morton.hpp"

namespace capsflow::ibm {

namespace {

using Eigen::Vector3d;

// A line that only grazes the surface (a small normal) says nothing of the distance: a point
// within reach of the surface has a line with |n_a| >= 1/sqrt(3) where it is nearest, and
// nearly that where that line crosses.
constexpr double kLeastNormal = 0.5;

// Boxes of side `reach` over the membrane's bounding box, marked where a triangle's bounding
// box lies within one box: a point within reach of the membrane lies in a marked box (the
// cells far from it need only their side).
class NearBoxes {
 public:
  NearBoxes(const Eigen::Matrix3Xd& x, std::span<const std::array<int, 3>> triangles, const Vector3d& lo,
            const Vector3d& hi, double reach)
      : lo_(lo.array() - 2.0 * reach), side_(reach) {
    for (int d = 0; d < 3; ++d) n_[d] = static_cast<long>(std::ceil((hi[d] - lo[d]) / reach)) + 5;
    marked_.assign(static_cast<std::size_t>(n_[0] * n_[1] * n_[2]), 0);
    for (const auto& tri : triangles) {
      std::array<long, 3> first{}, last{};
      for (int d = 0; d < 3; ++d) {
        const double a = x(d, tri[0]), b = x(d, tri[1]), c = x(d, tri[2]);
        first[static_cast<std::size_t>(d)] = bin(d, std::min({a, b, c}));
        last[static_cast<std::size_t>(d)] = bin(d, std::max({a, b, c}));
      }
      for (long i = first[0]; i <= last[0]; ++i)
        for (long j = first[1]; j <= last[1]; ++j)
          for (long k = first[2]; k <= last[2]; ++k) marked_[index(i, j, k)] = 1;
    }
    // Grown by one box along each axis in turn: the 27 boxes around every marked one.
    for (int d = 0; d < 3; ++d) {
      const std::vector<std::uint8_t> before = marked_;
      for (long i = 0; i < n_[0]; ++i)
        for (long j = 0; j < n_[1]; ++j)
          for (long k = 0; k < n_[2]; ++k) {
            std::array<long, 3> at{i, j, k};
            for (const long step : {-1L, 1L}) {
              at[static_cast<std::size_t>(d)] += step;
              if (at[static_cast<std::size_t>(d)] >= 0 && at[static_cast<std::size_t>(d)] < n_[d] &&
                  before[index(at[0], at[1], at[2])] != 0)
                marked_[index(i, j, k)] = 1;
              at[static_cast<std::size_t>(d)] -= step;
            }
          }
    }
  }
  [[nodiscard]] bool near(const Vector3d& q) const {
    long i[3];
    for (int d = 0; d < 3; ++d) {
      i[d] = static_cast<long>(std::floor((q[d] - lo_[d]) / side_));
      if (i[d] < 0 || i[d] >= n_[d]) return false;
    }
    return marked_[index(i[0], i[1], i[2])] != 0;
  }

 private:
  [[nodiscard]] std::size_t index(long i, long j, long k) const { return static_cast<std::size_t>((i * n_[1] + j) * n_[2] + k); }
  [[nodiscard]] long bin(int d, double v) const {
    return std::clamp(static_cast<long>(std::floor((v - lo_[d]) / side_)), 1L, n_[d] - 2);
  }
  Vector3d lo_;
  double side_;
  long n_[3]{};
  std::vector<std::uint8_t> marked_;
};

// The centre of cell ijk of level l (in the brick's coordinates, or beyond across periodic sides).
Vector3d cell_centre(const tree::Tree<3>& t, int l, const std::array<long, 3>& ijk) {
  const auto& o = t.options();
  const double hl = t.cell_size(l);
  return {o.origin[0] + (static_cast<double>(ijk[0]) + 0.5) * hl, o.origin[1] + (static_cast<double>(ijk[1]) + 0.5) * hl,
          o.origin[2] + (static_cast<double>(ijk[2]) + 0.5) * hl};
}

// A leaf within reach of the membrane's bounding box: its level, its coordinates in the
// membrane's frame (in cells of its level), and whether it lies near the membrane.
struct Candidate {
  tree::Index leaf = tree::kNone;
  int level = 0;
  std::array<long, 3> ijk{};
  bool near = false;
};

// The owned leaves of t whose centres lie in [lo, hi] (or an image of it across periodic
// sides, shifts in root cells), found by descending from the roots into the cells that meet
// it, with their coordinates in the box's frame; a leaf in reach of two images (a membrane
// longer than a period) is taken once.
std::vector<Candidate> find_candidates(const tree::Tree<3>& t, const std::vector<std::array<long, 3>>& shifts,
                                       const Vector3d& reach_lo, const Vector3d& reach_hi) {
  const auto& o = t.options();
  std::vector<Candidate> candidates;
  std::vector<std::uint8_t> seen;  // owned leaves already taken through an earlier image
  struct Visit {
    tree::Index cell;
    int level;
    std::array<long, 3> ijk;  // in the brick
  };
  std::vector<Visit> stack;
  for (const auto& shift : shifts) {
    // The box in the brick's frame, in cells of each level: [box_lo[l], box_hi[l]] per axis.
    std::vector<std::array<long, 3>> box_lo(static_cast<std::size_t>(t.max_level() + 1)), box_hi(box_lo.size());
    for (std::size_t l = 0; l < box_lo.size(); ++l)
      for (int d = 0; d < 3; ++d) {
        const double hl = t.cell_size(static_cast<int>(l));
        const double offset = static_cast<double>(shift[static_cast<std::size_t>(d)]) * t.cell_size(0) - o.origin[static_cast<std::size_t>(d)];
        box_lo[l][static_cast<std::size_t>(d)] = static_cast<long>(std::floor((reach_lo[d] + offset) / hl));
        box_hi[l][static_cast<std::size_t>(d)] = static_cast<long>(std::floor((reach_hi[d] + offset) / hl));
      }
    auto meets = [&](int l, const std::array<long, 3>& ijk) {
      const auto& a = box_lo[static_cast<std::size_t>(l)];
      const auto& b = box_hi[static_cast<std::size_t>(l)];
      return ijk[0] >= a[0] && ijk[0] <= b[0] && ijk[1] >= a[1] && ijk[1] <= b[1] && ijk[2] >= a[2] && ijk[2] <= b[2];
    };
    const auto& roots = t.level(0);
    for (tree::Index c = roots.active_begin(); c < roots.active_end(); ++c) {
      const auto k = t.coords(c);
      stack.push_back({c, 0, {k[0], k[1], k[2]}});
    }
    while (!stack.empty()) {
      const Visit v = stack.back();
      stack.pop_back();
      if (!meets(v.level, v.ijk)) continue;
      const tree::Level<3>& lv = t.level(v.level);
      if (lv.is_leaf(v.cell)) {
        if (!t.owns(v.cell)) continue;
        std::array<long, 3> ijk{};
        for (std::size_t d = 0; d < 3; ++d) ijk[d] = v.ijk[d] - shift[d] * (1L << v.level);
        const Vector3d q = cell_centre(t, v.level, ijk);
        if (!((q.array() >= reach_lo.array()).all() && (q.array() <= reach_hi.array()).all())) continue;
        if (shifts.size() > 1) {  // a membrane longer than a period meets a leaf twice
          if (seen.empty()) seen.assign(static_cast<std::size_t>(t.num_cells()), 0);
          if (std::exchange(seen[static_cast<std::size_t>(v.cell)], 1) != 0) continue;
        }
        candidates.push_back({v.cell, v.level, ijk, false});
        continue;
      }
      const tree::Index first = lv.first_child[static_cast<std::size_t>(v.cell - lv.base)];
      for (int b = tree::kChildren<3> - 1; b >= 0; --b) {  // popped in the curve's order
        std::array<long, 3> child{};
        for (int d = 0; d < 3; ++d)
          child[static_cast<std::size_t>(d)] = 2 * v.ijk[static_cast<std::size_t>(d)] + tree::child_bit(b, d);
        stack.push_back({first + b, v.level + 1, child});
      }
    }
  }
  return candidates;
}

geometry::AxisCrossings lines_along(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x,
                                    std::span<const std::array<int, 3>> triangles, int axis, int level,
                                    const Vector3d& lo, const Vector3d& hi) {
  const auto& origin = t.options().origin;
  const double h = t.cell_size(level);
  geometry::LineGrid g;
  g.axis = axis;
  g.h = h;
  for (int e = 0; e < 2; ++e) {
    const auto b = static_cast<std::size_t>((axis + 1 + e) % 3);
    g.origin[static_cast<std::size_t>(e)] = origin[b];
    g.lo[static_cast<std::size_t>(e)] = static_cast<long>(std::floor((lo[static_cast<int>(b)] - origin[b]) / h)) - 1;
    g.hi[static_cast<std::size_t>(e)] = static_cast<long>(std::ceil((hi[static_cast<int>(b)] - origin[b]) / h)) + 1;
  }
  return geometry::AxisCrossings(x, triangles, g);
}

// The distance of q (the centre of cell ijk) to the membrane from the plane of the crossing
// nearest it along each of its three lines, the line most normal to the surface; -1 if no
// line crosses steeply enough.
double plane_distance(const std::array<const geometry::AxisCrossings*, 3>& lines, const std::array<long, 3>& ijk,
                      const Vector3d& q) {
  double best_normal = kLeastNormal, distance = -1.0;
  for (int a = 0; a < 3; ++a) {
    const auto line = lines[static_cast<std::size_t>(a)]->line(ijk[static_cast<std::size_t>((a + 1) % 3)],
                                                                ijk[static_cast<std::size_t>((a + 2) % 3)]);
    if (line.empty()) continue;
    const auto above = std::lower_bound(line.begin(), line.end(), q[a],
                                        [](const geometry::AxisCrossing& c, double s) { return c.s < s; });
    const geometry::AxisCrossing* nearest = above != line.end() ? &*above : nullptr;
    if (above != line.begin() && (nearest == nullptr || q[a] - std::prev(above)->s < nearest->s - q[a]))
      nearest = &*std::prev(above);
    if (const double n = std::abs(nearest->normal); n >= best_normal) {
      best_normal = n;
      distance = std::abs((q[a] - nearest->s) * nearest->normal);
    }
  }
  return distance;
}

}  // namespace

std::vector<InsideCell> inside_cells(const tree::Tree<3>& t, const Eigen::Matrix3Xd& vertices,
                                     std::span<const std::array<int, 3>> triangles, KernelKind kernel, int level) {
  std::vector<InsideCell> out;
  if (vertices.cols() == 0 || triangles.empty()) return out;
  const double h = t.cell_size(level);
  const double reach = 0.5 * support_of(kernel) * h;
  const Vector3d lo = vertices.rowwise().minCoeff(), hi = vertices.rowwise().maxCoeff();
  const Vector3d reach_lo = lo.array() - reach, reach_hi = hi.array() + reach;

  // The periodic images of the membrane that come within reach of the brick, as shifts in
  // root cells (a whole number of cells at every level).
  const auto& o = t.options();
  std::vector<std::array<long, 3>> shifts;
  for (int sx = -1; sx <= 1; ++sx)
    for (int sy = -1; sy <= 1; ++sy)
      for (int sz = -1; sz <= 1; ++sz) {
        const std::array<long, 3> s{sx, sy, sz};
        bool valid = true;
        for (int d = 0; d < 3; ++d) {
          const auto u = static_cast<std::size_t>(d);
          const double period = o.roots[u] * t.cell_size(0), shift = static_cast<double>(s[u]) * period;
          if (s[u] != 0 && !o.periodic[u]) valid = false;
          if (reach_hi[d] + shift < o.origin[u] || reach_lo[d] + shift > o.origin[u] + period) valid = false;
        }
        if (valid) shifts.push_back({s[0] * o.roots[0], s[1] * o.roots[1], s[2] * o.roots[2]});
      }

  // Four independent parts, side by side: the leaves within reach of the bounding box, the
  // boxes near the membrane, and the lines along the three axes at the spreading level
  // (along x they give the side of every leaf far from the membrane: the line point nearest
  // its centre lies within h / sqrt(2) of it, closer than the membrane; a leaf near the
  // membrane reads the three lines through its own centre).
  std::vector<Candidate> candidates;
  std::optional<NearBoxes> near_boxes;
  std::vector<std::array<geometry::AxisCrossings, 3>> lines(static_cast<std::size_t>(t.max_level() + 1));
#pragma omp parallel for schedule(dynamic, 1)
  for (int part = 0; part < 5; ++part) {
    if (part == 0) candidates = find_candidates(t, shifts, reach_lo, reach_hi);
    else if (part == 1) near_boxes.emplace(vertices, triangles, lo, hi, reach);
    else lines[static_cast<std::size_t>(level)][static_cast<std::size_t>(part - 2)] = lines_along(t, vertices, triangles, part - 2, level, lo, hi);
  }
  const auto m = static_cast<tree::Index>(candidates.size());
#pragma omp parallel for schedule(static) if (m > tree::kParallelMin)
  for (tree::Index i = 0; i < m; ++i) {
    Candidate& c = candidates[static_cast<std::size_t>(i)];
    c.near = near_boxes->near(cell_centre(t, c.level, c.ijk));
  }
  // Near leaves of other levels (a tree not refined at the membrane) read their own level's lines.
  std::vector<int> other_levels;
  for (const Candidate& c : candidates)
    if (c.near && c.level != level && std::find(other_levels.begin(), other_levels.end(), c.level) == other_levels.end())
      other_levels.push_back(c.level);
  const auto num_other = static_cast<int>(3 * other_levels.size());
#pragma omp parallel for schedule(dynamic)
  for (int b = 0; b < num_other; ++b) {
    const int l = other_levels[static_cast<std::size_t>(b / 3)];
    lines[static_cast<std::size_t>(l)][static_cast<std::size_t>(b % 3)] = lines_along(t, vertices, triangles, b % 3, l, lo, hi);
  }
  const geometry::AxisCrossings& side_lines = lines[static_cast<std::size_t>(level)][0];

  std::vector<double> value(candidates.size(), 0.0);
  with_kernel(kernel, [&]<Kernel K>(K) {
#pragma omp parallel for schedule(static) if (m > tree::kParallelMin)
    for (tree::Index i = 0; i < m; ++i) {
      const Candidate& c = candidates[static_cast<std::size_t>(i)];
      const Vector3d q = cell_centre(t, c.level, c.ijk);
      double d = -1.0;
      bool inside = false;
      if (c.near) {
        const auto& at = lines[static_cast<std::size_t>(c.level)];
        inside = at[0].winding_below(c.ijk[1], c.ijk[2], q[0]) > 0;
        d = plane_distance({&at[0], &at[1], &at[2]}, c.ijk, q);
      } else {
        const auto line = [&](int e) { return static_cast<long>(std::floor((q[e] - o.origin[static_cast<std::size_t>(e)]) / h)); };
        inside = side_lines.winding_below(line(1), line(2), q[0]) > 0;
      }
      value[static_cast<std::size_t>(i)] = d < 0.0 || d >= reach ? (inside ? 1.0 : 0.0) : K::cumulative((inside ? d : -d) / h);
    }
  });
  for (std::size_t i = 0; i < candidates.size(); ++i)
    if (value[i] > 0.0) out.push_back({candidates[i].leaf, value[i]});
  return out;
}

}  // namespace capsflow::ibm
