#include "geometry/axis_crossings.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/Geometry>

namespace capsflow::geometry {

namespace {

using Point2 = std::array<double, 2>;

double orient(const Point2& u, const Point2& v, const Point2& q) {
  return (v[0] - u[0]) * (q[1] - u[1]) - (v[1] - u[1]) * (q[0] - u[0]);
}

// orient(u, v, q) computed from the lower endpoint, so that edge(v, u, q) is exactly
// -edge(u, v, q): the two triangles sharing an edge see a point on its two sides, or on it.
double edge(const Point2& u, const Point2& v, const Point2& q) {
  return u < v ? orient(u, v, q) : -orient(v, u, q);
}

// Whether a point on the edge from u to v (of a counter-clockwise triangle) belongs to it:
// the edges whose direction points down, or right along a horizontal. The triangle on the
// other side runs the edge the other way and gets the point exactly when this one does not.
bool holds_edge(const Point2& u, const Point2& v) {
  const double dy = v[1] - u[1];
  return dy < 0.0 || (dy == 0.0 && v[0] - u[0] > 0.0);
}

}  // namespace

AxisCrossings::AxisCrossings(const Eigen::Matrix3Xd& vertices, std::span<const std::array<int, 3>> triangles,
                             const LineGrid& grid)
    : grid_(grid) {
  const int a = grid.axis, b = (a + 1) % 3, c = (a + 2) % 3;
  const long lines = (grid.hi[0] - grid.lo[0] + 1) * (grid.hi[1] - grid.lo[1] + 1);
  std::vector<std::pair<long, AxisCrossing>> found;
  for (const auto& tri : triangles) {
    std::array<Point2, 3> p;
    for (int v = 0; v < 3; ++v) {
      const auto col = vertices.col(tri[static_cast<std::size_t>(v)]);
      p[static_cast<std::size_t>(v)] = {col[b], col[c]};
    }
    const double area = orient(p[0], p[1], p[2]);  // = the 3D normal's component along a
    if (area == 0.0) continue;  // parallel to the lines: its neighbours hold its edges
    // Lines whose (j + 1/2) h lies within the projection's bounding box (most triangles hold
    // none at the coarse levels).
    std::array<long, 2> first{}, last{};
    for (std::size_t e = 0; e < 2; ++e) {
      const double lo = std::min({p[0][e], p[1][e], p[2][e]}), hi = std::max({p[0][e], p[1][e], p[2][e]});
      first[e] = std::max(grid.lo[e], static_cast<long>(std::ceil((lo - grid.origin[e]) / grid.h - 0.5)));
      last[e] = std::min(grid.hi[e], static_cast<long>(std::floor((hi - grid.origin[e]) / grid.h - 0.5)));
    }
    if (first[0] > last[0] || first[1] > last[1]) continue;
    const double sign = area > 0.0 ? 1.0 : -1.0;
    const Eigen::Vector3d n3 = (vertices.col(tri[1]) - vertices.col(tri[0])).cross(vertices.col(tri[2]) - vertices.col(tri[0]));
    const double normal = area / n3.norm();
    for (long j = first[0]; j <= last[0]; ++j)
      for (long k = first[1]; k <= last[1]; ++k) {
        const Point2 q{grid.origin[0] + (static_cast<double>(j) + 0.5) * grid.h,
                       grid.origin[1] + (static_cast<double>(k) + 0.5) * grid.h};
        std::array<double, 3> w{};  // barycentric weights times |area|: of vertices 0, 1, 2
        bool inside = true;
        for (int v = 0; v < 3 && inside; ++v) {
          const Point2& u = p[static_cast<std::size_t>((v + 1) % 3)];
          const Point2& t = p[static_cast<std::size_t>((v + 2) % 3)];
          const double e = sign * edge(u, t, q);
          w[static_cast<std::size_t>(v)] = e;
          inside = e > 0.0 || (e == 0.0 && (sign > 0.0 ? holds_edge(u, t) : holds_edge(t, u)));
        }
        if (!inside) continue;
        const double total = w[0] + w[1] + w[2];
        double s = 0.0;
        for (int v = 0; v < 3; ++v) s += w[static_cast<std::size_t>(v)] * vertices(a, tri[static_cast<std::size_t>(v)]);
        // total > 0 unless rounding: then any vertex's coordinate is as good.
        s = total > 0.0 ? s / total : vertices(a, tri[0]);
        found.push_back({index(j, k), AxisCrossing{s, normal}});
      }
  }
  // Bucketed by line (a counting sort), then each line's few crossings in order along it.
  start_.assign(static_cast<std::size_t>(lines + 1), 0);
  for (const auto& f : found) ++start_[static_cast<std::size_t>(f.first + 1)];
  for (long i = 0; i < lines; ++i) start_[static_cast<std::size_t>(i + 1)] += start_[static_cast<std::size_t>(i)];
  crossings_.resize(found.size());
  std::vector<long> next(start_.begin(), start_.end() - 1);
  for (const auto& f : found) crossings_[static_cast<std::size_t>(next[static_cast<std::size_t>(f.first)]++)] = f.second;
  for (long i = 0; i < lines; ++i)
    std::sort(crossings_.begin() + start_[static_cast<std::size_t>(i)], crossings_.begin() + start_[static_cast<std::size_t>(i + 1)],
              [](const AxisCrossing& x, const AxisCrossing& y) { return x.s < y.s; });
}

std::span<const AxisCrossing> AxisCrossings::line(long j, long k) const {
  if (start_.empty() || j < grid_.lo[0] || j > grid_.hi[0] || k < grid_.lo[1] || k > grid_.hi[1]) return {};
  const auto i = static_cast<std::size_t>(index(j, k));
  return {crossings_.data() + start_[i], static_cast<std::size_t>(start_[i + 1] - start_[i])};
}

int AxisCrossings::winding_below(long j, long k, double s) const {
  int w = 0;
  for (const AxisCrossing& x : line(j, k)) {
    if (!(x.s < s)) break;
    w += x.normal < 0.0 ? 1 : -1;
  }
  return w;
}

}  // namespace capsflow::geometry
