// Icosphere meshes (P1, P2) and reference-mesh validation.
#include "membrane/errors.hpp"
#include "membrane/mesh.hpp"

#include <Eigen/Geometry>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <utility>

namespace capsflow::membrane {
namespace {

using ::testing::HasSubstr;

std::int64_t undirected_edge_count(const Mesh& mesh) {
  std::set<std::pair<std::int32_t, std::int32_t>> edges;
  for (std::int64_t e = 0; e < mesh.element_count(); ++e) {
    const auto v = mesh.element(e);
    for (int i = 0; i < 3; ++i) edges.insert(std::minmax(v[i], v[(i + 1) % 3]));
  }
  return static_cast<std::int64_t>(edges.size());
}

TEST(membrane_mesh, IcosphereCountsAndEulerCharacteristic) {
  for (int level = 0; level <= 6; ++level) {
    const Mesh p1 = make_icosphere({.order = Order::p1, .level = level});
    EXPECT_EQ(p1.node_count(), icosphere_node_count(level));
    EXPECT_EQ(p1.element_count(), 20 * (std::int64_t{1} << (2 * level)));
    // V - E + F = 2 for a closed genus-0 triangulation.
    EXPECT_EQ(p1.node_count() - undirected_edge_count(p1) + p1.element_count(), 2) << "level " << level;
    if (level < min_icosphere_level_p2) continue;
    const Mesh p2 = make_icosphere({.order = Order::p2, .level = level});
    EXPECT_EQ(p2.node_count(), icosphere_node_count(level));
    EXPECT_EQ(p2.element_count(), 20 * (std::int64_t{1} << (2 * (level - 1))));
    // Vertices - edges + faces of the vertex triangulation = 2; the other nodes are edges.
    const std::int64_t edges = undirected_edge_count(p2);
    const std::int64_t vertices = p2.node_count() - edges;
    EXPECT_EQ(vertices - edges + p2.element_count(), 2) << "level " << level;
  }
  EXPECT_EQ(icosphere_node_count(5), 10242);
  EXPECT_EQ(icosphere_node_count(6), 40962);
}

TEST(membrane_mesh, NodesLieOnTheSphere) {
  const Eigen::Vector3d centre(0.3, -1.2, 4.0);
  for (const Order order : {Order::p1, Order::p2}) {
    const Mesh mesh = make_icosphere({.order = order, .level = 4, .radius = 0.85, .centre = centre});
    const Eigen::VectorXd r = (mesh.nodes.colwise() - centre).colwise().norm();
    EXPECT_LT((r.array() - 0.85).abs().maxCoeff(), 1e-15 * 8);
  }
}

TEST(membrane_mesh, P2NodesAreTheP1NodesWithMidEdgeNodesOnTheArcs) {
  for (int level = min_icosphere_level_p2; level <= 5; ++level) {
    const Mesh p1 = make_icosphere({.order = Order::p1, .level = level, .radius = 2.0});
    const Mesh p2 = make_icosphere({.order = Order::p2, .level = level, .radius = 2.0});
    EXPECT_EQ(p1.nodes, p2.nodes) << "level " << level;  // same subdivision, same order
    for (std::int64_t e = 0; e < p2.element_count(); ++e) {
      const auto v = p2.element(e);
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d arc_midpoint = 2.0 * (p2.nodes.col(v[k]) + p2.nodes.col(v[(k + 1) % 3])).normalized();
        ASSERT_LT((p2.nodes.col(v[3 + k]) - arc_midpoint).norm(), 1e-14) << "element " << e;
      }
    }
  }
}

TEST(membrane_mesh, IcospheresAreValidAndOutward) {
  for (const Order order : {Order::p1, Order::p2}) {
    const Mesh mesh = make_icosphere({.order = order, .level = 4});
    EXPECT_NO_THROW(validate_mesh(mesh));
    for (std::int64_t e = 0; e < mesh.element_count(); ++e) {
      const auto v = mesh.element(e);
      const Eigen::Vector3d n =
          (mesh.nodes.col(v[1]) - mesh.nodes.col(v[0])).cross(mesh.nodes.col(v[2]) - mesh.nodes.col(v[0]));
      ASSERT_GT(n.dot(mesh.nodes.col(v[0])), 0.0) << "element " << e;
    }
  }
}

TEST(membrane_mesh, LevelOutOfRangeNamesTheLevel) {
  const auto message = [](Order order, int level) {
    try {
      (void)make_icosphere({.order = order, .level = level});
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no exception");
  };
  EXPECT_THAT(message(Order::p1, -1), HasSubstr("subdivision level -1 is out of range for P1"));
  EXPECT_THAT(message(Order::p1, 7), HasSubstr("subdivision level 7 is out of range for P1 meshes (allowed 0..6)"));
  EXPECT_THAT(message(Order::p2, 2), HasSubstr("subdivision level 2 is out of range for P2 meshes (allowed 3..6)"));
  EXPECT_THAT(message(Order::p2, 7), HasSubstr("subdivision level 7"));
  try {
    (void)make_icosphere({.radius = -0.5});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("radius -0.5"));
  }
}

std::string validation_message(const Mesh& mesh) {
  try {
    validate_mesh(mesh);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no exception";
}

TEST(membrane_mesh, ValidationNamesDegenerateElements) {
  // A flat patch of three triangles; element 1 has collinear vertices.
  Mesh patch;
  patch.nodes.resize(3, 5);
  patch.nodes << 0, 1, 2, 0, 1,  //
      0, 0, 0, 1, 1,             //
      0, 0, 0, 0, 0;
  patch.elements = {0, 1, 3, 0, 1, 2, 1, 4, 3};
  EXPECT_THAT(validation_message(patch), HasSubstr("element 1 is degenerate: area element |g1 x g2| = 0"));
  EXPECT_THROW(validate_mesh(patch), ElementError);
  patch.elements = {0, 1, 3, 1, 1, 4};
  EXPECT_THAT(validation_message(patch), HasSubstr("element 1 is degenerate: node 1 appears twice"));
  patch.elements = {0, 1, 3, 1, 9, 4};
  EXPECT_THAT(validation_message(patch), HasSubstr("element 1 refers to node 9 outside 0..4"));
}

TEST(membrane_mesh, ValidationNamesInvertedElements) {
  Mesh mesh = make_icosphere({.order = Order::p1, .level = 2});
  std::swap(mesh.elements[3 * 17 + 1], mesh.elements[3 * 17 + 2]);  // flip element 17
  EXPECT_THAT(validation_message(mesh), HasSubstr("element 17 is inverted: 3 of its edges"));

  Mesh inside_out = make_icosphere({.order = Order::p1, .level = 2});
  for (std::int64_t e = 0; e < inside_out.element_count(); ++e)
    std::swap(inside_out.elements[3 * e + 1], inside_out.elements[3 * e + 2]);
  EXPECT_THAT(validation_message(inside_out), HasSubstr("all elements are inverted"));

  // A P2 element folded over itself: a mid-edge node pushed across the opposite vertex.
  Mesh p2 = make_icosphere({.order = Order::p2, .level = 3});
  const auto v = p2.element(40);
  p2.nodes.col(v[4]) = p2.nodes.col(v[1]) + 2.0 * (p2.nodes.col(v[0]) - p2.nodes.col(v[1]));
  const std::string message = validation_message(p2);
  EXPECT_THAT(message, HasSubstr("element 40 is"));
  EXPECT_THAT(message, ::testing::AnyOf(HasSubstr("inverted (folded)"), HasSubstr("degenerate")));
}

}  // namespace
}  // namespace capsflow::membrane
