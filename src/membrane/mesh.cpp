// Icosphere construction and reference-mesh validation (mesh.hpp).
#include "membrane/mesh.hpp"

#include "membrane/element_geometry.hpp"
#include "membrane/errors.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace capsflow::membrane {

namespace {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> nodes;  // on the unit sphere
  std::vector<std::array<std::int32_t, 3>> triangles;
};

TriangleMesh icosahedron() {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  TriangleMesh m;
  m.nodes = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
             {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : m.nodes) p.normalize();
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  // Orientation by construction, not by trusting the table: outward normals.
  for (auto& tri : m.triangles) {
    const Eigen::Vector3d n =
        (m.nodes[tri[1]] - m.nodes[tri[0]]).cross(m.nodes[tri[2]] - m.nodes[tri[0]]);
    if (n.dot(m.nodes[tri[0]]) < 0) std::swap(tri[1], tri[2]);
  }
  return m;
}

// Projected midpoint of edge (a, b), created once per undirected edge.
class MidpointCache {
 public:
  explicit MidpointCache(std::vector<Eigen::Vector3d>& nodes) : nodes_(nodes) {}
  std::int32_t operator()(std::int32_t a, std::int32_t b) {
    const auto lo = static_cast<std::uint64_t>(std::min(a, b));
    const auto hi = static_cast<std::uint64_t>(std::max(a, b));
    const auto [it, inserted] =
        cache_.try_emplace((lo << 32) | hi, static_cast<std::int32_t>(nodes_.size()));
    if (inserted) nodes_.push_back((nodes_[a] + nodes_[b]).normalized());
    return it->second;
  }

 private:
  std::vector<Eigen::Vector3d>& nodes_;
  std::unordered_map<std::uint64_t, std::int32_t> cache_;
};

TriangleMesh subdivide(TriangleMesh m) {
  TriangleMesh out;
  out.nodes = std::move(m.nodes);
  out.triangles.reserve(4 * m.triangles.size());
  MidpointCache mid(out.nodes);
  for (const auto& [a, b, c] : m.triangles) {
    const std::int32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    out.triangles.push_back({a, ab, ca});
    out.triangles.push_back({b, bc, ab});
    out.triangles.push_back({c, ca, bc});
    out.triangles.push_back({ab, bc, ca});
  }
  return out;
}

Eigen::Matrix3Xd place(const std::vector<Eigen::Vector3d>& unit, double radius,
                       const Eigen::Vector3d& centre) {
  Eigen::Matrix3Xd x(3, static_cast<Eigen::Index>(unit.size()));
  for (std::size_t i = 0; i < unit.size(); ++i)
    x.col(static_cast<Eigen::Index>(i)) = centre + radius * unit[i];
  return x;
}

std::string element_error_prefix(std::int64_t e) {
  return "membrane mesh: element " + std::to_string(e) + " ";
}

// Degeneracy and (for P2) folding of one reference element, tested at its vertices,
// mid-edges and centroid: the area element must be positive and the surface normal
// g1 x g2 must agree with the normal of the vertex triangle.
template <int Nn>
void check_element_shape(const Mesh& mesh, std::int64_t e) {
  const auto x = gather<Nn>(mesh.nodes, mesh.element(e).data());
  double scale2 = 0.0;
  for (int i = 0; i < 3; ++i) scale2 = std::max(scale2, (x[(i + 1) % 3] - x[i]).squaredNorm());
  const Eigen::Vector3d chord = chord_normal<Nn>(x);
  constexpr double tolerance = 1e-10;
  const double points[7][2] = {{0, 0}, {1, 0}, {0, 1}, {0.5, 0}, {0.5, 0.5}, {0, 0.5},
                               {1.0 / 3, 1.0 / 3}};
  const int count = Nn == 3 ? 1 : 7;
  for (int p = 0; p < count; ++p) {
    const auto s = shape_functions<Nn>(points[p][0], points[p][1]);
    const auto [g1, g2] = tangents<Nn>(x, s.d_xi.data(), s.d_eta.data());
    const Eigen::Vector3d n = g1.cross(g2);
    if (!(n.norm() > tolerance * scale2)) {
      std::ostringstream msg;
      msg << element_error_prefix(e) << "is degenerate: area element |g1 x g2| = " << n.norm()
          << " at (xi, eta) = (" << points[p][0] << ", " << points[p][1]
          << ") for a squared edge length " << scale2;
      throw ElementError(msg.str(), e);
    }
    if (n.dot(chord) <= 0.0) {
      std::ostringstream msg;
      msg << element_error_prefix(e) << "is inverted (folded): its normal at (xi, eta) = ("
          << points[p][0] << ", " << points[p][1]
          << ") opposes the normal of its vertex triangle, g1 x g2 . n_chord = " << n.dot(chord);
      throw ElementError(msg.str(), e);
    }
  }
}

}  // namespace

std::vector<std::array<int, 3>> flat_triangles(const Mesh& mesh) {
  std::vector<std::array<int, 3>> out;
  const std::int64_t n = mesh.element_count();
  out.reserve(static_cast<std::size_t>(n) * (mesh.order == Order::p2 ? 4 : 1));
  for (std::int64_t e = 0; e < n; ++e) {
    const auto v = mesh.element(e);
    if (mesh.order == Order::p1) {
      out.push_back({v[0], v[1], v[2]});
    } else {
      out.push_back({v[0], v[3], v[5]});
      out.push_back({v[3], v[1], v[4]});
      out.push_back({v[5], v[4], v[2]});
      out.push_back({v[3], v[4], v[5]});
    }
  }
  return out;
}

Mesh make_icosphere(const IcosphereOptions& options) {
  const bool p2 = options.order == Order::p2;
  const int min_level = p2 ? min_icosphere_level_p2 : min_icosphere_level_p1;
  if (options.level < min_level || options.level > max_icosphere_level) {
    throw std::invalid_argument(
        "make_icosphere: subdivision level " + std::to_string(options.level) +
        " is out of range for " + (p2 ? "P2" : "P1") + " meshes (allowed " +
        std::to_string(min_level) + ".." + std::to_string(max_icosphere_level) + ")");
  }
  if (!(options.radius > 0.0) || !std::isfinite(options.radius)) {
    std::ostringstream msg;
    msg << "make_icosphere: radius " << options.radius << " must be positive and finite";
    throw std::invalid_argument(msg.str());
  }
  TriangleMesh m = icosahedron();
  for (int l = 0; l < options.level - (p2 ? 1 : 0); ++l) m = subdivide(std::move(m));

  Mesh mesh;
  mesh.order = options.order;
  if (!p2) {
    mesh.elements.reserve(3 * m.triangles.size());
    for (const auto& tri : m.triangles) mesh.elements.insert(mesh.elements.end(), tri.begin(), tri.end());
  } else {
    mesh.elements.reserve(6 * m.triangles.size());
    MidpointCache mid(m.nodes);
    for (const auto& [a, b, c] : m.triangles) {
      const std::int32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
      mesh.elements.insert(mesh.elements.end(), {a, b, c, ab, bc, ca});
    }
  }
  mesh.nodes = place(m.nodes, options.radius, options.centre);
  return mesh;
}

void validate_mesh(const Mesh& mesh) {
  const int npe = nodes_per_element(mesh.order);
  if (mesh.elements.size() % static_cast<std::size_t>(npe) != 0) {
    throw std::invalid_argument("membrane mesh: connectivity size " +
                                std::to_string(mesh.elements.size()) +
                                " is not a multiple of " + std::to_string(npe));
  }
  const std::int64_t n_nodes = mesh.node_count();
  const std::int64_t n_elements = mesh.element_count();
  if (n_elements == 0) throw std::invalid_argument("membrane mesh: no elements");
  for (std::int64_t e = 0; e < n_elements; ++e) {
    const auto nodes = mesh.element(e);
    for (int i = 0; i < npe; ++i) {
      if (nodes[i] < 0 || nodes[i] >= n_nodes) {
        throw ElementError(element_error_prefix(e) + "refers to node " + std::to_string(nodes[i]) +
                               " outside 0.." + std::to_string(n_nodes - 1),
                           e);
      }
      for (int j = 0; j < i; ++j)
        if (nodes[i] == nodes[j])
          throw ElementError(element_error_prefix(e) + "is degenerate: node " +
                                 std::to_string(nodes[i]) + " appears twice",
                             e);
    }
    if (npe == 3) check_element_shape<3>(mesh, e);
    else check_element_shape<6>(mesh, e);
  }

  // Consistent orientation: in an oriented surface each directed vertex edge is used once.
  std::unordered_map<std::uint64_t, std::int64_t> owner;
  owner.reserve(static_cast<std::size_t>(3 * n_elements));
  std::vector<int> conflicts(static_cast<std::size_t>(n_elements), 0);
  const auto key = [](std::int32_t a, std::int32_t b) {
    return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint64_t>(b);
  };
  for (std::int64_t e = 0; e < n_elements; ++e) {
    const auto v = mesh.element(e);
    for (int i = 0; i < 3; ++i) {
      const auto [it, inserted] = owner.try_emplace(key(v[i], v[(i + 1) % 3]), e);
      if (!inserted) {
        ++conflicts[static_cast<std::size_t>(e)];
        ++conflicts[static_cast<std::size_t>(it->second)];
      }
    }
  }
  const auto worst = std::max_element(conflicts.begin(), conflicts.end());
  if (*worst > 0) {
    const auto e = static_cast<std::int64_t>(worst - conflicts.begin());
    throw ElementError(element_error_prefix(e) + "is inverted: " + std::to_string(*worst) +
                           " of its edges run in the same direction as in a neighbouring element",
                       e);
  }
  bool closed = true;
  for (const auto& [k, e] : owner) {
    const auto a = static_cast<std::int32_t>(k >> 32), b = static_cast<std::int32_t>(k & 0xffffffffu);
    if (!owner.contains(key(b, a))) {
      closed = false;
      break;
    }
  }
  if (closed) {
    // Sign of the enclosed volume of the vertex polyhedron (enough to tell in from out).
    const Eigen::Vector3d origin = mesh.nodes.rowwise().mean();
    double six_volume = 0.0;
    for (std::int64_t e = 0; e < n_elements; ++e) {
      const auto v = mesh.element(e);
      six_volume += (mesh.nodes.col(v[0]) - origin)
                        .dot((mesh.nodes.col(v[1]) - origin).cross(mesh.nodes.col(v[2]) - origin));
    }
    if (!(six_volume > 0.0)) {
      std::ostringstream msg;
      msg << "membrane mesh: all elements are inverted (normals point inwards): enclosed volume "
          << six_volume / 6.0 << " <= 0";
      throw std::invalid_argument(msg.str());
    }
  }
}

}  // namespace capsflow::membrane
