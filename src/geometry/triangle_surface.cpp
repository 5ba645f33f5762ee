#include "geometry/triangle_surface.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>
#include <fmt/format.h>

namespace capsflow::geometry {

namespace {

using Eigen::Vector3d;

// Which feature of a triangle holds the nearest point.
enum class Feature { face, edge01, edge12, edge20, vertex0, vertex1, vertex2 };

// The nearest point of triangle (a, b, c) to p and its feature (Ericson, Real-Time Collision
// Detection, 5.1.5: the Voronoi regions of the vertices, then the edges, then the face).
std::pair<Vector3d, Feature> nearest_on_triangle(const Vector3d& p, const Vector3d& a, const Vector3d& b,
                                                 const Vector3d& c) {
  const Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return {a, Feature::vertex0};
  const Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return {b, Feature::vertex1};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return {a + d1 / (d1 - d3) * ab, Feature::edge01};
  const Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return {c, Feature::vertex2};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return {a + d2 / (d2 - d6) * ac, Feature::edge20};
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return {b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b), Feature::edge12};
  const double denom = 1.0 / (va + vb + vc);
  return {a + ab * (vb * denom) + ac * (vc * denom), Feature::face};
}

class TriangleSurface final : public Solid {
 public:
  explicit TriangleSurface(TriangleMesh mesh) : m_(std::move(mesh)) {
    check_and_build_normals();
    std::vector<int> order(m_.triangles.size());
    std::iota(order.begin(), order.end(), 0);
    nodes_.reserve(2 * order.size());
    build(order, 0, static_cast<int>(order.size()));
  }

  double signed_distance(const Vector3d& x) const override {
    double best = std::numeric_limits<double>::infinity();
    int best_t = -1;
    Vector3d best_p = Vector3d::Zero();
    Feature best_f = Feature::face;
    nearest(0, x, best, best_t, best_p, best_f);
    const double d = std::sqrt(best);
    const Vector3d n = pseudonormal(best_t, best_f);
    return (x - best_p).dot(n) >= 0 ? d : -d;  // outside the surface: fluid, positive
  }

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    int left = -1, right = -1;  // children, or -1 in a leaf
    int first = 0, count = 0;   // a leaf's triangles in leaf_triangles_
  };

  Vector3d vertex(int t, int k) const { return m_.vertices.col(m_.triangles[static_cast<std::size_t>(t)][static_cast<std::size_t>(k)]); }

  void check_and_build_normals() {
    const auto n = static_cast<int>(m_.vertices.cols());
    if (m_.triangles.empty()) throw std::invalid_argument("surface: no triangles");
    if (!m_.vertices.allFinite()) throw std::invalid_argument("surface: a vertex is not finite");
    face_normal_.resize(m_.triangles.size());
    vertex_normal_.assign(static_cast<std::size_t>(n), Vector3d::Zero());
    std::map<std::pair<int, int>, int> directed;  // edge (from, to) -> triangle
    double volume = 0.0;
    for (std::size_t t = 0; t < m_.triangles.size(); ++t) {
      const auto& tri = m_.triangles[t];
      for (const int v : tri)
        if (v < 0 || v >= n) throw std::invalid_argument(fmt::format("surface: triangle {} names vertex {} of {}", t, v, n));
      const Vector3d a = vertex(static_cast<int>(t), 0), b = vertex(static_cast<int>(t), 1), c = vertex(static_cast<int>(t), 2);
      const Vector3d cross = (b - a).cross(c - a);
      const double scale = std::max({(b - a).squaredNorm(), (c - a).squaredNorm(), (c - b).squaredNorm()});
      if (!(cross.norm() > 1e-12 * scale)) throw std::invalid_argument(fmt::format("surface: triangle {} is degenerate (no area)", t));
      face_normal_[t] = cross.normalized();
      volume += a.dot(b.cross(c)) / 6.0;
      for (int k = 0; k < 3; ++k) {
        const int from = tri[static_cast<std::size_t>(k)], to = tri[static_cast<std::size_t>((k + 1) % 3)];
        if (!directed.emplace(std::pair{from, to}, static_cast<int>(t)).second)
          throw std::invalid_argument(fmt::format(
              "surface: edge {}-{} is run in the same direction by two triangles (inconsistent orientation or a non-manifold edge)",
              from, to));
        // The angle at the vertex weighs the face normal into the vertex's pseudonormal.
        const Vector3d p = m_.vertices.col(tri[static_cast<std::size_t>(k)]);
        const Vector3d u = (m_.vertices.col(tri[static_cast<std::size_t>((k + 1) % 3)]) - p).normalized();
        const Vector3d w = (m_.vertices.col(tri[static_cast<std::size_t>((k + 2) % 3)]) - p).normalized();
        vertex_normal_[static_cast<std::size_t>(tri[static_cast<std::size_t>(k)])] +=
            std::acos(std::clamp(u.dot(w), -1.0, 1.0)) * face_normal_[t];
      }
    }
    for (const auto& [edge, t] : directed)
      if (!directed.contains({edge.second, edge.first}))
        throw std::invalid_argument(fmt::format("surface: edge {}-{} borders one triangle only (the surface is not closed)",
                                                edge.first, edge.second));
    if (!(volume > 0.0))
      throw std::invalid_argument(fmt::format("surface: the enclosed volume is {} (normals point inwards?)", volume));
    edge_normal_.resize(m_.triangles.size());
    for (std::size_t t = 0; t < m_.triangles.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        const auto& tri = m_.triangles[t];
        const int from = tri[static_cast<std::size_t>(k)], to = tri[static_cast<std::size_t>((k + 1) % 3)];
        const int other = directed.at({to, from});
        edge_normal_[t][static_cast<std::size_t>(k)] = face_normal_[t] + face_normal_[static_cast<std::size_t>(other)];
      }
  }

  Vector3d pseudonormal(int t, Feature f) const {
    const auto& tri = m_.triangles[static_cast<std::size_t>(t)];
    switch (f) {
      case Feature::face: return face_normal_[static_cast<std::size_t>(t)];
      case Feature::edge01: return edge_normal_[static_cast<std::size_t>(t)][0];
      case Feature::edge12: return edge_normal_[static_cast<std::size_t>(t)][1];
      case Feature::edge20: return edge_normal_[static_cast<std::size_t>(t)][2];
      case Feature::vertex0: return vertex_normal_[static_cast<std::size_t>(tri[0])];
      case Feature::vertex1: return vertex_normal_[static_cast<std::size_t>(tri[1])];
      case Feature::vertex2: return vertex_normal_[static_cast<std::size_t>(tri[2])];
    }
    return face_normal_[static_cast<std::size_t>(t)];
  }

  // A node over order[begin, end): split at the median of the centroids along the box's
  // longest axis until a few triangles are left.
  int build(std::vector<int>& order, int begin, int end) {
    const int id = static_cast<int>(nodes_.size());
    nodes_.push_back({});
    Eigen::AlignedBox3d box;
    for (int i = begin; i < end; ++i)
      for (int k = 0; k < 3; ++k) box.extend(vertex(order[static_cast<std::size_t>(i)], k));
    nodes_[static_cast<std::size_t>(id)].box = box;
    if (end - begin <= 4) {
      nodes_[static_cast<std::size_t>(id)].first = static_cast<int>(leaf_triangles_.size());
      nodes_[static_cast<std::size_t>(id)].count = end - begin;
      for (int i = begin; i < end; ++i) leaf_triangles_.push_back(order[static_cast<std::size_t>(i)]);
      return id;
    }
    int axis = 0;
    box.sizes().maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    auto centroid = [&](int t) { return vertex(t, 0)[axis] + vertex(t, 1)[axis] + vertex(t, 2)[axis]; };
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](int a, int b) { return centroid(a) < centroid(b); });
    const int left = build(order, begin, mid);
    const int right = build(order, mid, end);
    nodes_[static_cast<std::size_t>(id)].left = left;
    nodes_[static_cast<std::size_t>(id)].right = right;
    return id;
  }

  void nearest(int id, const Vector3d& x, double& best, int& best_t, Vector3d& best_p, Feature& best_f) const {
    const Node& node = nodes_[static_cast<std::size_t>(id)];
    if (node.box.squaredExteriorDistance(x) >= best) return;
    if (node.left < 0) {
      for (int i = node.first; i < node.first + node.count; ++i) {
        const int t = leaf_triangles_[static_cast<std::size_t>(i)];
        const auto [p, f] = nearest_on_triangle(x, vertex(t, 0), vertex(t, 1), vertex(t, 2));
        // Ties (a shared edge or vertex) keep the lower triangle: the same pseudonormal.
        if (const double d = (x - p).squaredNorm(); d < best || (d == best && t < best_t)) {
          best = d;
          best_t = t;
          best_p = p;
          best_f = f;
        }
      }
      return;
    }
    // The nearer child first: its triangles bound the other's search.
    const double l = nodes_[static_cast<std::size_t>(node.left)].box.squaredExteriorDistance(x);
    const double r = nodes_[static_cast<std::size_t>(node.right)].box.squaredExteriorDistance(x);
    const int first = l <= r ? node.left : node.right, second = l <= r ? node.right : node.left;
    nearest(first, x, best, best_t, best_p, best_f);
    nearest(second, x, best, best_t, best_p, best_f);
  }

  TriangleMesh m_;
  std::vector<Vector3d> face_normal_, vertex_normal_;
  std::vector<std::array<Vector3d, 3>> edge_normal_;  // per triangle, edges 01, 12, 20
  std::vector<Node> nodes_;
  std::vector<int> leaf_triangles_;
};

}  // namespace

SolidPtr triangle_surface(TriangleMesh mesh) { return std::make_shared<TriangleSurface>(std::move(mesh)); }

}  // namespace capsflow::geometry
