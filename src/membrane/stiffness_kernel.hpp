#pragma once
// The element kernel of the membrane's tangent stiffness K = d2E/dX2 = -dF/dX (the Hessian
// of the energy of force_kernel.hpp), for an implicit coupling that linearises the nodal
// forces about the current positions (issue 30).
//
// With N_ia = dN_i/dxi_a and, at a quadrature point of weight w = w_q sqrt(det G),
//   a_i = G^ab N_ia g_b,   b_i = adj(g)^ab N_ia g_b / det G   (d tr C / dx_i = 2 a_i,
//                                                             d det C / dx_i = 2 b_i),
// the 3x3 block of nodes i, j is
//   K_ij = w [ 4 W_tt a_i a_j^T + 4 W_td (a_i b_j^T + b_i a_j^T) + 4 W_dd b_i b_j^T
//            + 2 W_tr G^ab N_ia N_jb I + (2 W_det / det G) (adj(g)^ab N_ia N_jb I + T_ij) ],
// where T_ij = d(adj(g)^ab N_ia g_b)/dx_j minus its identity part:
//   T_ij = (2 N_i1 N_j2 - N_i2 N_j1) g_1 g_2^T + (2 N_i2 N_j1 - N_i1 N_j2) g_2 g_1^T
//        - N_i1 N_j1 g_2 g_2^T - N_i2 N_j2 g_1 g_1^T.
// The first line is the material stiffness, the second the geometric one (the tension S
// acting on the change of the tangents); K is symmetric block by block (K_ji = K_ij^T).
#include "membrane/force_kernel.hpp"

#include <Eigen/Core>

namespace capsflow::membrane {

template <int Nn>
using ElementStiffness = Eigen::Matrix<double, 3 * Nn, 3 * Nn>;

// Writes the element's stiffness into k (overwritten), rows and columns 3 i + component.
template <int Nn, MembraneLaw Law>
inline void element_stiffness(const Law& law, const ElementNodes<Nn>& x, const ShapeDerivatives<Nn>* d,
                              const ReferencePoint* ref, int nq, ElementStiffness<Nn>& k) noexcept {
  k.setZero();
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  for (int q = 0; q < nq; ++q) {
    const ReferencePoint& r = ref[q];
    const ShapeDerivatives<Nn>& dq = derivatives_at<Nn>(d, q);
    const auto p = point_kinematics<Nn>(x, dq, r);
    const auto [w_tr, w_det] = law.derivatives(p.tr, p.det);
    const auto s = law.second_derivatives(p.tr, p.det);
    const Eigen::Vector3d& g1 = p.g.g1;
    const Eigen::Vector3d& g2 = p.g.g2;
    // adj(g)^ab / det G = (g22, -g12; -g12, g11) / det G.
    const double h11 = p.g22 * r.inv_det_g, h12 = -p.g12 * r.inv_det_g, h22 = p.g11 * r.inv_det_g;
    std::array<Eigen::Vector3d, Nn> a, b;
    for (int i = 0; i < Nn; ++i) {
      const double n1 = dq[0][i], n2 = dq[1][i];
      a[i] = (r.gi11 * n1 + r.gi12 * n2) * g1 + (r.gi12 * n1 + r.gi22 * n2) * g2;
      b[i] = (h11 * n1 + h12 * n2) * g1 + (h12 * n1 + h22 * n2) * g2;
    }
    const double w = r.w_da;
    const double geometric = 2.0 * w * w_det * r.inv_det_g;
    const Eigen::Matrix3d g12t = g1 * g2.transpose(), g21t = g2 * g1.transpose();
    const Eigen::Matrix3d g11t = g1 * g1.transpose(), g22t = g2 * g2.transpose();
    for (int i = 0; i < Nn; ++i) {
      const double i1 = dq[0][i], i2 = dq[1][i];
      for (int j = i; j < Nn; ++j) {  // the lower blocks mirror these after the loop
        const double j1 = dq[0][j], j2 = dq[1][j];
        const double metric = r.gi11 * i1 * j1 + r.gi12 * (i1 * j2 + i2 * j1) + r.gi22 * i2 * j2;
        const double adjugate = p.g22 * i1 * j1 - p.g12 * (i1 * j2 + i2 * j1) + p.g11 * i2 * j2;
        Eigen::Matrix3d block = 4.0 * w *
                                (s.w_tr_tr * a[i] * a[j].transpose() +
                                 s.w_tr_det * (a[i] * b[j].transpose() + b[i] * a[j].transpose()) +
                                 s.w_det_det * b[i] * b[j].transpose());
        block += (2.0 * w * w_tr * metric + geometric * adjugate) * identity;
        block += geometric * ((2.0 * i1 * j2 - i2 * j1) * g12t + (2.0 * i2 * j1 - i1 * j2) * g21t -
                              i1 * j1 * g22t - i2 * j2 * g11t);
        k.template block<3, 3>(3 * i, 3 * j) += block;
      }
    }
  }
  for (int i = 0; i < Nn; ++i)
    for (int j = 0; j < i; ++j) k.template block<3, 3>(3 * i, 3 * j) = k.template block<3, 3>(3 * j, 3 * i).transpose();
}

}  // namespace capsflow::membrane
