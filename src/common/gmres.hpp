#pragma once
// Flexible GMRES (Saad 1993), unrestarted, for the systems solved over whole flow steps: the
// implicit coupling's on the node displacements (ibm/implicit_coupling.cpp) and the flow's on
// its pressure (fluid/ns_pressure_iterations.cpp): matrix-free (each product is a flow step), a right
// preconditioner that may change between iterations, and an inner product the caller
// supplies (on N ranks a sum over the capsules that every rank forms alike). Modified
// Gram-Schmidt, Givens rotations; the residual norm comes from the rotations at no cost.
// Eigen's GMRES (unsupported module) needs a matrix type and its own dot products, which
// would not reduce over ranks.
#include <Eigen/Core>

#include <cmath>
#include <vector>

namespace capsflow {

struct GmresResult {
  int iterations = 0;      // products with the operator
  double residual = 0.0;   // |b - A x| / |b| (from the rotations)
  bool converged = false;  // residual <= tolerance
};

// Solves A x = b from x = 0 to |b - A x| <= tolerance |b|, with at most max_iterations
// products: apply(v) = A v, precondition(v) ~ A^-1 v, dot(a, b) the inner product.
template <class Apply, class Precondition, class Dot>
GmresResult fgmres(const Apply& apply, const Precondition& precondition, const Dot& dot, const Eigen::VectorXd& b,
                   Eigen::VectorXd& x, double tolerance, int max_iterations) {
  GmresResult out;
  x = Eigen::VectorXd::Zero(b.size());
  const double beta = std::sqrt(dot(b, b));
  if (!(beta > 0.0)) {
    out.converged = true;
    return out;
  }
  const int m = max_iterations;
  std::vector<Eigen::VectorXd> v, z;
  v.push_back(b / beta);
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(m + 1, m);
  Eigen::VectorXd cs = Eigen::VectorXd::Zero(m), sn = Eigen::VectorXd::Zero(m);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(m + 1);
  g[0] = beta;
  int j = 0;
  for (; j < m; ++j) {
    z.push_back(precondition(v[static_cast<std::size_t>(j)]));
    Eigen::VectorXd w = apply(z.back());
    for (int i = 0; i <= j; ++i) {
      h(i, j) = dot(w, v[static_cast<std::size_t>(i)]);
      w -= h(i, j) * v[static_cast<std::size_t>(i)];
    }
    const double w_norm = std::sqrt(dot(w, w));
    h(j + 1, j) = w_norm;
    for (int i = 0; i < j; ++i) {  // the earlier rotations on the new column
      const double t = cs[i] * h(i, j) + sn[i] * h(i + 1, j);
      h(i + 1, j) = -sn[i] * h(i, j) + cs[i] * h(i + 1, j);
      h(i, j) = t;
    }
    const double r = std::hypot(h(j, j), h(j + 1, j));
    cs[j] = h(j, j) / r;
    sn[j] = h(j + 1, j) / r;
    h(j, j) = r;
    h(j + 1, j) = 0.0;
    g[j + 1] = -sn[j] * g[j];
    g[j] = cs[j] * g[j];
    out.residual = std::abs(g[j + 1]) / beta;
    // Converged, or the Krylov space is invariant (the solution is exact in it).
    if (out.residual <= tolerance || !(w_norm > 0.0)) {
      ++j;
      break;
    }
    v.push_back(w / w_norm);
  }
  out.iterations = j;
  // y = R^-1 g (upper triangular), x = Z y.
  Eigen::VectorXd y = h.topLeftCorner(j, j).triangularView<Eigen::Upper>().solve(g.head(j));
  for (int i = 0; i < j; ++i) x += y[i] * z[static_cast<std::size_t>(i)];
  out.converged = out.residual <= tolerance;
  return out;
}

}  // namespace capsflow
