#pragma once
// From nodal forces back to a load per unit area. The nodal forces are the weak form of the
// surface load, F_i = int q N_i dS; the load density q in the element space is the L2
// projection  M q = F  with the consistent mass matrix of the current surface
//   M_ij = int N_i N_j dS   (collapsed Gauss rule of degree 2 for P1, 6 for P2: exact for
//                           P1 and far below the discretisation error for curved P2).
// Needed because a P2 vertex shape function integrates to (nearly) zero on an element, so
// F_i / (lumped area) means nothing for P2. Solved per component by conjugate gradients.
#include "membrane/mesh.hpp"

#include <Eigen/Core>
#include <Eigen/SparseCore>

namespace capsflow::membrane {

[[nodiscard]] Eigen::SparseMatrix<double> consistent_mass_matrix(const Mesh& mesh, const Eigen::Matrix3Xd& x);

struct LoadDensity {
  Eigen::Matrix3Xd q;        // load per unit current area at the nodes
  int iterations = 0;        // largest CG iteration count of the three components
  double residual = 0.0;     // largest relative residual |M q - F| / |F|
};

// Solves M q = F to the relative tolerance; the caller decides what a residual means.
[[nodiscard]] LoadDensity load_density(const Mesh& mesh, const Eigen::Matrix3Xd& x,
                                       const Eigen::Matrix3Xd& nodal_forces, double tolerance = 1e-13);

}  // namespace capsflow::membrane
