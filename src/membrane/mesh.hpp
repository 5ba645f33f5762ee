#pragma once
// Membrane meshes as plain data: node positions and element connectivity, P1 or P2.
//
// A P1 element is a flat triangle (nodes 0, 1, 2 counter-clockwise seen from outside).
// A P2 element adds the mid-edge nodes 3 = (0,1), 4 = (1,2), 5 = (2,0); its geometry is the
// quadratic map x(xi, eta) = sum_i N_i(xi, eta) x_i, so a P2 sphere is curved.
//
// Icospheres: the icosahedron, subdivided `level` times (each triangle into four, new nodes
// projected radially on the sphere), has 10 * 4^level + 2 nodes. For P2 the same node set is
// grouped into 6-node elements: the level-(L-1) triangles with their projected edge midpoints,
// so a P2 icosphere of level L has the same nodes as the P1 one (10 242 nodes at level 5 are
// 20 480 P1 or 5 120 P2 triangles, as in the seed paper).
#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace capsflow::membrane {

enum class Order : int { p1 = 1, p2 = 2 };

// Calls f(std::integral_constant<int, Nn>{}) with the nodes per element of `order`: the one
// place an order becomes a template argument. A switch without default, so that -Wswitch
// flags a new order left out, where a ternary would silently treat it as P2.
template <class F>
decltype(auto) with_element_nodes(Order order, F&& f) {
  switch (order) {
    case Order::p1: return f(std::integral_constant<int, 3>{});
    case Order::p2: return f(std::integral_constant<int, 6>{});
  }
  throw std::logic_error("membrane: unknown element order");
}

[[nodiscard]] constexpr int nodes_per_element(Order order) noexcept {
  switch (order) {
    case Order::p1: return 3;
    case Order::p2: return 6;
  }
  return 0;  // unreachable: the switch is exhaustive
}

struct Mesh {
  Order order = Order::p1;
  Eigen::Matrix3Xd nodes;              // column i = position of node i
  std::vector<std::int32_t> elements;  // nodes_per_element(order) indices per element

  [[nodiscard]] std::int64_t node_count() const noexcept { return nodes.cols(); }
  [[nodiscard]] std::int64_t element_count() const noexcept {
    return static_cast<std::int64_t>(elements.size()) / nodes_per_element(order);
  }
  [[nodiscard]] std::span<const std::int32_t> element(std::int64_t e) const noexcept {
    const auto n = static_cast<std::size_t>(nodes_per_element(order));
    return {elements.data() + static_cast<std::size_t>(e) * n, n};
  }
};

struct IcosphereOptions {
  Order order = Order::p1;
  int level = 5;  // nodes = 10 * 4^level + 2; P1: 0..6 (12..40 962), P2: 3..6 (642..40 962)
  double radius = 1.0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
};

inline constexpr int min_icosphere_level_p1 = 0;
inline constexpr int max_icosphere_level = 6;
inline constexpr int min_icosphere_level_p2 = 3;

[[nodiscard]] constexpr std::int64_t icosphere_node_count(int level) noexcept {
  return 10 * (std::int64_t{1} << (2 * level)) + 2;
}

// Throws std::invalid_argument naming the level (or radius) when out of range.
[[nodiscard]] Mesh make_icosphere(const IcosphereOptions& options);

// The surface as flat triangles on the mesh's nodes, counter-clockwise seen from outside: a
// P1 element itself, a P2 element as the four triangles of its corner and mid-edge nodes
// (0 3 5, 3 1 4, 5 4 2, 3 4 5). What the inside of a membrane on the grid is cut by
// (ibm/indicator.hpp); the curved P2 surface lies within O(h^2) of it.
[[nodiscard]] std::vector<std::array<int, 3>> flat_triangles(const Mesh& mesh);

// Checks a reference mesh: indices in range and distinct within an element, every element
// non-degenerate (positive area element at its centroid and vertices, no fold of a P2
// element), orientation consistent between neighbours (no directed edge used twice) and,
// for a closed surface, outward (positive enclosed volume). Throws ElementError naming the
// element and the offending value.
void validate_mesh(const Mesh& mesh);

}  // namespace capsflow::membrane
