#pragma once
// The element kernel of the membrane's tangent stiffness K = d2E/dX2 = -dF/dX (the Hessian
// of the energy of force_kernel.hpp), for an implicit coupling that linearises the nodal
// forces about the current positions (issue 30).
//
// At a quadrature point E depends on the nodes only through the tangents g_a = sum_i N_ia x_i
// (N_ia = dN_i/dxi_a), so the element's 3x3 block of nodes i, j is
//   K_ij = sum_q sum_ab N_ia N_jb H_ab,
// with H the 6x6 Hessian of w W(tr C, det C) in (g_1, g_2), w = w_q sqrt(det G). With
// alpha_a = G^ab g_b and beta_a = adj(g)^ab g_b / det G (d tr C / dg_a = 2 alpha_a,
// d det C / dg_a = 2 beta_a),
//   H = w [ 4 W_tt alpha alpha^T + 4 W_td (alpha beta^T + beta alpha^T) + 4 W_dd beta beta^T
//         + 2 W_tr (G^ab I) + (W_det / det G) D ],
// where D = d2 det(g) / dg2 has the blocks
//   D_11 = 2 (g22 I - g_2 g_2^T),  D_22 = 2 (g11 I - g_1 g_1^T),
//   D_12 = 4 g_1 g_2^T - 2 g_2 g_1^T - 2 g12 I = D_21^T.
// The first line is the material stiffness, the second the geometric one (the tension acting
// on the change of the tangents). Where the membrane is compressed in a direction, the
// geometric part is negative (wrinkling modes) and K is indefinite. The positive variant
// replaces each H by its projection on the positive semi-definite matrices (its negative
// eigenvalues set to zero: the "projected Newton" Hessian of Teran et al. 2005), which makes K
// positive semi-definite and equal to the Hessian wherever every H already is.
#include "membrane/force_kernel.hpp"

#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace capsflow::membrane {

template <int Nn>
using ElementStiffness = Eigen::Matrix<double, 3 * Nn, 3 * Nn>;

using TangentHessian = Eigen::Matrix<double, 6, 6>;

// H of one quadrature point (see above).
template <MembraneLaw Law>
[[nodiscard]] inline TangentHessian tangent_hessian(const Law& law, const PointKinematics& p,
                                                    const ReferencePoint& r) noexcept {
  const auto [w_tr, w_det] = law.derivatives(p.tr, p.det);
  const auto s = law.second_derivatives(p.tr, p.det);
  const Eigen::Vector3d& g1 = p.g.g1;
  const Eigen::Vector3d& g2 = p.g.g2;
  Eigen::Matrix<double, 6, 1> alpha, beta;
  alpha << r.gi11 * g1 + r.gi12 * g2, r.gi12 * g1 + r.gi22 * g2;
  beta << (p.g22 * g1 - p.g12 * g2) * r.inv_det_g, (p.g11 * g2 - p.g12 * g1) * r.inv_det_g;
  TangentHessian h = 4.0 * (s.w_tr_tr * alpha * alpha.transpose() +
                            s.w_tr_det * (alpha * beta.transpose() + beta * alpha.transpose()) +
                            s.w_det_det * beta * beta.transpose());
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const double c = w_det * r.inv_det_g;
  h.block<3, 3>(0, 0) += 2.0 * w_tr * r.gi11 * identity + 2.0 * c * (p.g22 * identity - g2 * g2.transpose());
  h.block<3, 3>(3, 3) += 2.0 * w_tr * r.gi22 * identity + 2.0 * c * (p.g11 * identity - g1 * g1.transpose());
  const Eigen::Matrix3d off = 2.0 * w_tr * r.gi12 * identity +
                              c * (4.0 * g1 * g2.transpose() - 2.0 * g2 * g1.transpose() - 2.0 * p.g12 * identity);
  h.block<3, 3>(0, 3) += off;
  h.block<3, 3>(3, 0) += off.transpose();
  return r.w_da * h;
}

// H with its negative eigenvalues set to zero. A pivoted LDL^T first (a tenth of the
// eigensolver's cost) passes the points already positive, those in tension.
[[nodiscard]] inline TangentHessian positive_part(const TangentHessian& h) {
  const Eigen::LDLT<TangentHessian> ldlt(h);
  if (ldlt.info() == Eigen::Success && ldlt.isPositive()) return h;
  const Eigen::SelfAdjointEigenSolver<TangentHessian> eig(h);
  const auto& values = eig.eigenvalues();
  if (values[0] >= 0.0) return h;
  return eig.eigenvectors() * values.cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
}

// Writes the element's stiffness into k (overwritten), rows and columns 3 i + component;
// with `positive`, from the positive parts of the points' H. A collapsed or folded element
// clears status.ok (as element_forces does).
template <int Nn, MembraneLaw Law>
inline void element_stiffness(const Law& law, const ElementNodes<Nn>& x, const ShapeDerivatives<Nn>* d,
                              const ReferencePoint* ref, int nq, bool positive, ElementStiffness<Nn>& k,
                              ElementStatus& status) {
  k.setZero();
  const Eigen::Vector3d chord = chord_normal<Nn>(x);
  for (int q = 0; q < nq; ++q) {
    const ShapeDerivatives<Nn>& dq = derivatives_at<Nn>(d, q);
    const auto p = point_kinematics<Nn>(x, dq, ref[q]);
    status.ok = status.ok && acceptable<Nn>(p, chord);
    if (!status.ok) return;
    TangentHessian h = tangent_hessian(law, p, ref[q]);
    if (positive) h = positive_part(h);
    for (int i = 0; i < Nn; ++i) {
      const double i1 = dq[0][i], i2 = dq[1][i];
      for (int j = i; j < Nn; ++j) {  // the lower blocks mirror these after the loop
        const double j1 = dq[0][j], j2 = dq[1][j];
        k.template block<3, 3>(3 * i, 3 * j) += i1 * j1 * h.block<3, 3>(0, 0) + i1 * j2 * h.block<3, 3>(0, 3) +
                                                i2 * j1 * h.block<3, 3>(3, 0) + i2 * j2 * h.block<3, 3>(3, 3);
      }
    }
  }
  for (int i = 0; i < Nn; ++i)
    for (int j = 0; j < i; ++j) k.template block<3, 3>(3 * i, 3 * j) = k.template block<3, 3>(3 * j, 3 * i).transpose();
}

}  // namespace capsflow::membrane
