#include "ibm/indicator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>

#include "geometry/axis_crossings.hpp"

namespace capsflow::ibm {

namespace {

using Eigen::Vector3d;

constexpr double kLeastNormal = 0.5;

// The crossings of one level's grid lines along the three axes with the membrane.
struct LevelLines {
  std::array<geometry::AxisCrossings, 3> along;
};

LevelLines lines_of(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, std::span<const std::array<int, 3>> triangles,
                    int level, const Vector3d& lo, const Vector3d& hi) {
  const auto& origin = t.options().origin;
  const double h = t.cell_size(level);
  LevelLines out;
  for (int a = 0; a < 3; ++a) {
    geometry::LineGrid g;
    g.axis = a;
    g.h = h;
    for (int e = 0; e < 2; ++e) {
      const int b = (a + 1 + e) % 3;
      g.origin[static_cast<std::size_t>(e)] = origin[static_cast<std::size_t>(b)];
      g.lo[static_cast<std::size_t>(e)] = static_cast<long>(std::floor((lo[b] - origin[static_cast<std::size_t>(b)]) / h)) - 1;
      g.hi[static_cast<std::size_t>(e)] = static_cast<long>(std::ceil((hi[b] - origin[static_cast<std::size_t>(b)]) / h)) + 1;
    }
    out.along[static_cast<std::size_t>(a)] = geometry::AxisCrossings(x, triangles, g);
  }
  return out;
}

// The line of `lines` through q (a cell centre of its level, in the membrane's frame).
std::array<long, 2> line_through(const geometry::AxisCrossings& lines, const Vector3d& q) {
  const geometry::LineGrid& g = lines.grid();
  std::array<long, 2> jk{};
  for (int e = 0; e < 2; ++e) {
    const int b = (g.axis + 1 + e) % 3;
    jk[static_cast<std::size_t>(e)] = std::lround((q[b] - g.origin[static_cast<std::size_t>(e)]) / g.h - 0.5);
  }
  return jk;
}

// I at q from its level's lines; reach: the transition's half width, h the spreading level's
// cell size, C the kernel's cumulative integral.
template <class Cumulative>
double inside_at(const LevelLines& lines, const Vector3d& q, double reach, double h, Cumulative C) {
  const auto& x_lines = lines.along[0];
  const auto jk = line_through(x_lines, q);
  const bool inside = x_lines.winding_below(jk[0], jk[1], q[0]) > 0;
  // The crossing nearest q along each axis; of those, the most normal to the surface.
  double best_normal = 0.0, distance = 0.0;
  bool found = false;
  for (int a = 0; a < 3; ++a) {
    const auto& along = lines.along[static_cast<std::size_t>(a)];
    const auto ajk = line_through(along, q);
    const auto line = along.line(ajk[0], ajk[1]);
    if (line.empty()) continue;
    const auto above = std::lower_bound(line.begin(), line.end(), q[a],
                                        [](const geometry::AxisCrossing& c, double s) { return c.s < s; });
    const geometry::AxisCrossing* nearest = nullptr;
    if (above != line.end()) nearest = &*above;
    if (above != line.begin() && (nearest == nullptr || q[a] - std::prev(above)->s < nearest->s - q[a]))
      nearest = &*std::prev(above);
    const double n = std::abs(nearest->normal);
    if (n > best_normal) {
      best_normal = n;
      distance = std::abs((q[a] - nearest->s) * nearest->normal);
      found = true;
    }
  }
  // A line that only grazes the surface (small normal) says nothing of the distance: a point
  // within reach of the surface has a line with |n_a| >= 1/sqrt(3) where it is nearest, and
  // nearly that where that line crosses.
  if (!found || best_normal < kLeastNormal || distance >= reach) return inside ? 1.0 : 0.0;
  return C((inside ? distance : -distance) / h);
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

  // The periodic images of the membrane that come within reach of the brick.
  const auto& o = t.options();
  std::vector<Vector3d> shifts;
  for (int sx = -1; sx <= 1; ++sx)
    for (int sy = -1; sy <= 1; ++sy)
      for (int sz = -1; sz <= 1; ++sz) {
        const std::array<int, 3> s{sx, sy, sz};
        Vector3d shift = Vector3d::Zero();
        bool valid = true;
        for (int d = 0; d < 3; ++d) {
          const double period = o.roots[static_cast<std::size_t>(d)] * t.cell_size(0);
          if (s[static_cast<std::size_t>(d)] != 0 && !o.periodic[static_cast<std::size_t>(d)]) valid = false;
          shift[d] = s[static_cast<std::size_t>(d)] * period;
          const double brick_lo = o.origin[static_cast<std::size_t>(d)], brick_hi = brick_lo + period;
          if (reach_hi[d] + shift[d] < brick_lo || reach_lo[d] + shift[d] > brick_hi) valid = false;
        }
        if (valid) shifts.push_back(shift);
      }

  // The owned leaves within reach of an image's bounding box (the first image that holds it).
  const std::span<const tree::Index> owned = t.owned_leaves();
  const auto n = static_cast<tree::Index>(owned.size());
  std::vector<std::int8_t> image(owned.size(), -1);
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
  for (tree::Index i = 0; i < n; ++i) {
    const auto p = t.center(owned[static_cast<std::size_t>(i)]);
    for (std::size_t s = 0; s < shifts.size(); ++s) {
      const Vector3d q = Vector3d(p[0], p[1], p[2]) - shifts[s];
      if ((q.array() >= reach_lo.array()).all() && (q.array() <= reach_hi.array()).all()) {
        image[static_cast<std::size_t>(i)] = static_cast<std::int8_t>(s);
        break;
      }
    }
  }
  std::vector<tree::Index> near;
  std::vector<int> levels;
  for (tree::Index i = 0; i < n; ++i)
    if (image[static_cast<std::size_t>(i)] >= 0) {
      near.push_back(i);
      const int l = t.level_of(owned[static_cast<std::size_t>(i)]);
      if (std::find(levels.begin(), levels.end(), l) == levels.end()) levels.push_back(l);
    }
  std::sort(levels.begin(), levels.end());
  std::vector<LevelLines> lines(levels.size());
  const auto num_levels = static_cast<int>(levels.size());
#pragma omp parallel for schedule(dynamic)
  for (int k = 0; k < num_levels; ++k)
    lines[static_cast<std::size_t>(k)] = lines_of(t, vertices, triangles, levels[static_cast<std::size_t>(k)], lo, hi);

  std::vector<double> value(near.size(), 0.0);
  const auto m = static_cast<tree::Index>(near.size());
  with_kernel(kernel, [&]<Kernel K>(K) {
#pragma omp parallel for schedule(static) if (m > tree::kParallelMin)
    for (tree::Index i = 0; i < m; ++i) {
      const tree::Index leaf = owned[static_cast<std::size_t>(near[static_cast<std::size_t>(i)])];
      const auto p = t.center(leaf);
      const Vector3d q = Vector3d(p[0], p[1], p[2]) - shifts[static_cast<std::size_t>(image[static_cast<std::size_t>(near[static_cast<std::size_t>(i)])])];
      const auto k = std::lower_bound(levels.begin(), levels.end(), t.level_of(leaf)) - levels.begin();
      value[static_cast<std::size_t>(i)] = inside_at(lines[static_cast<std::size_t>(k)], q, reach, h,
                                                     [](double s) { return K::cumulative(s); });
    }
  });
  for (std::size_t i = 0; i < near.size(); ++i)
    if (value[i] > 0.0) out.push_back({owned[static_cast<std::size_t>(near[i])], value[i]});
  return out;
}

}  // namespace capsflow::ibm
