// Consistent mass matrix and load recovery M q = F (equations in load.hpp).
#include "membrane/load.hpp"

#include "membrane/element_geometry.hpp"
#include "membrane/quadrature.hpp"

#include <Eigen/IterativeLinearSolvers>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

namespace capsflow::membrane {

namespace {

template <int Nn>
void add_element_mass(const Mesh& mesh, const Eigen::Matrix3Xd& x, std::vector<Eigen::Triplet<double>>& t) {
  const QuadratureRule& rule = gauss_rule_for_degree(Nn == 3 ? 2 : 6);
  for (std::int64_t e = 0; e < mesh.element_count(); ++e) {
    const auto nodes = mesh.element(e);
    const auto xe = gather<Nn>(x, nodes.data());
    Eigen::Matrix<double, Nn, Nn> m = Eigen::Matrix<double, Nn, Nn>::Zero();
    for (const auto& p : rule.points) {
      const auto s = shape_functions<Nn>(p.xi, p.eta);
      const auto [g1, g2] = tangents<Nn>(xe, s.d_xi.data(), s.d_eta.data());
      const Eigen::Map<const Eigen::Matrix<double, Nn, 1>> n(s.n.data());
      m += (p.weight * g1.cross(g2).norm()) * n * n.transpose();
    }
    for (int i = 0; i < Nn; ++i)
      for (int j = 0; j < Nn; ++j) t.emplace_back(nodes[i], nodes[j], m(i, j));
  }
}

}  // namespace

Eigen::SparseMatrix<double> consistent_mass_matrix(const Mesh& mesh, const Eigen::Matrix3Xd& x) {
  if (x.cols() != mesh.node_count())
    throw std::invalid_argument("consistent_mass_matrix: configuration has " + std::to_string(x.cols()) +
                                " nodes, the mesh " + std::to_string(mesh.node_count()));
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(mesh.elements.size() * static_cast<std::size_t>(nodes_per_element(mesh.order)));
  with_element_nodes(mesh.order, [&](auto nn) { add_element_mass<nn()>(mesh, x, triplets); });
  Eigen::SparseMatrix<double> m(mesh.node_count(), mesh.node_count());
  m.setFromTriplets(triplets.begin(), triplets.end());
  return m;
}

LoadDensity load_density(const Mesh& mesh, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& nodal_forces,
                         double tolerance) {
  if (nodal_forces.cols() != x.cols())
    throw std::invalid_argument("load_density: " + std::to_string(nodal_forces.cols()) +
                                " nodal forces for " + std::to_string(x.cols()) + " nodes");
  const Eigen::SparseMatrix<double> m = consistent_mass_matrix(mesh, x);
  Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg;
  cg.setTolerance(tolerance);
  cg.setMaxIterations(1000);
  cg.compute(m);
  LoadDensity out;
  out.q.resize(3, x.cols());
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd f = nodal_forces.row(k).transpose();
    const Eigen::VectorXd q = cg.solve(f);
    out.q.row(k) = q.transpose();
    out.iterations = std::max(out.iterations, static_cast<int>(cg.iterations()));
    const double norm = f.norm();
    out.residual = std::max(out.residual, norm > 0.0 ? (m * q - f).norm() / norm : 0.0);
  }
  return out;
}

}  // namespace capsflow::membrane
