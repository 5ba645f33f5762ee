#pragma once
// The law and element cases the force and stiffness tests run through, and a generic
// deformed configuration of the seed ellipsoid.
#include "membrane/forces.hpp"
#include "membrane/mesh.hpp"
#include "membrane/shapes.hpp"

#include <Eigen/Core>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace capsflow::membrane::test {

struct Case {
  Order order;
  int level;
  LawParameters law;
  int quadrature_degree;
};

inline std::string describe(const Case& s) {
  return std::string(s.order == Order::p1 ? "P1" : "P2") + " level " + std::to_string(s.level) +
         (s.law.kind == LawKind::skalak ? " Skalak C=" + std::to_string(s.law.c) : " neo-Hookean") +
         " quadrature degree " + std::to_string(s.quadrature_degree);
}

inline const std::vector<Case>& setups() {
  static const std::vector<Case> s = {
      {Order::p1, 2, {.kind = LawKind::skalak, .gs = 1.3, .c = 1.0}, 0},
      {Order::p1, 2, {.kind = LawKind::neo_hookean, .gs = 0.7}, 0},
      {Order::p2, 3, {.kind = LawKind::skalak, .gs = 1.3, .c = 10.0}, 0},
      {Order::p2, 3, {.kind = LawKind::neo_hookean, .gs = 0.7}, 0},
      {Order::p2, 3, {.kind = LawKind::skalak, .gs = 1.3, .c = 1.0}, 4},
  };
  return s;
}

// The seed ellipsoid with every node coordinate displaced randomly by up to 8% of the
// icosphere's edge length (about 1/2^level): a generic, three-dimensional, non-homogeneous
// deformation that folds no element.
inline Eigen::Matrix3Xd random_configuration(const Mesh& mesh, std::mt19937& rng) {
  const double amplitude = 0.08 * std::sqrt(12.0 / static_cast<double>(mesh.node_count()));
  std::uniform_real_distribution<double> u(-amplitude, amplitude);
  Eigen::Matrix3Xd x = seed_ellipsoid(mesh.nodes, Eigen::Vector3d::Zero());
  for (Eigen::Index i = 0; i < x.size(); ++i) x.data()[i] += u(rng);
  return x;
}

inline double max_norm(const Eigen::Matrix3Xd& f) { return f.colwise().norm().maxCoeff(); }

}  // namespace capsflow::membrane::test
