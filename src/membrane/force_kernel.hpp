#pragma once
// Element kernels of the membrane energy and nodal forces (pure functions of one element).
//
// Discrete equations. With reference covariant basis G_a and metric G_ab (precomputed per
// quadrature point: G^ab, 1/det G, w_q sqrt(det G)), and current tangents
// g_a = sum_i x_i dN_i/dxi_a, metric g_ab = g_a . g_b:
//   tr C  = G^ab g_ab,         det C = det g / det G,
//   E_e   = sum_q w_q sqrt(det G) W(tr C, det C),
//   S^ab  = 2 (W_tr G^ab + W_det adj(g)^ab / det G)      (second Piola-Kirchhoff tension),
//   F_i   = -dE_e/dx_i = -sum_q w_q sqrt(det G) S^ab g_a dN_i/dxi_b.
// sum_i dN_i = 0 makes the element's total force vanish and the symmetry of S its total
// torque, identically; E depends on x only through g_ab, hence is invariant under rigid
// motions. Nothing here allocates or divides by a current-configuration quantity.
#include "membrane/element_geometry.hpp"
#include "membrane/laws.hpp"

#include <array>
#include <limits>

namespace capsflow::membrane {

// Reference-configuration data of one quadrature point of one element.
struct ReferencePoint {
  double gi11, gi12, gi22;  // inverse reference metric G^ab
  double inv_det_g;         // 1 / det G
  double w_da;              // w_q sqrt(det G): reference area weight
};

// dN/dxi and dN/deta of the Nn shape functions at each quadrature point, stored as
// [q][0 = xi, 1 = eta][i].
template <int Nn>
using ShapeDerivatives = std::array<std::array<double, Nn>, 2>;

// P1 derivatives are the same constants at every point; returning them as compile-time
// constants lets the compiler fold the multiplications by -1, 0, 1.
template <int Nn>
[[nodiscard]] inline const ShapeDerivatives<Nn>& derivatives_at(const ShapeDerivatives<Nn>* d, int q) noexcept {
  if constexpr (Nn == 3) {
    static constexpr ShapeDerivatives<3> p1{{{-1.0, 1.0, 0.0}, {-1.0, 0.0, 1.0}}};
    return p1;
  } else {
    return d[q];
  }
}

// A point with det C at or below this (J < 1e-12) is a collapsed element.
inline constexpr double min_det_c = 1e-24;

struct ElementStatus {
  bool ok = true;
};

struct PointKinematics {
  Tangents g;
  double g11, g12, g22, tr, det;
};

template <int Nn>
[[nodiscard]] inline PointKinematics point_kinematics(const ElementNodes<Nn>& x,
                                                      const ShapeDerivatives<Nn>& d,
                                                      const ReferencePoint& r) noexcept {
  PointKinematics k{tangents<Nn>(x, d[0].data(), d[1].data()), 0, 0, 0, 0, 0};
  k.g11 = k.g.g1.squaredNorm();
  k.g12 = k.g.g1.dot(k.g.g2);
  k.g22 = k.g.g2.squaredNorm();
  k.tr = r.gi11 * k.g11 + 2.0 * r.gi12 * k.g12 + r.gi22 * k.g22;
  k.det = (k.g11 * k.g22 - k.g12 * k.g12) * r.inv_det_g;
  return k;
}

// For P2, an element folds when its surface normal turns against its vertex triangle's.
template <int Nn>
[[nodiscard]] inline bool acceptable(const PointKinematics& k, const Eigen::Vector3d& chord) noexcept {
  if (!(k.det > min_det_c) || !(k.det < std::numeric_limits<double>::infinity())) return false;
  if constexpr (Nn == 6) return k.g.g1.cross(k.g.g2).dot(chord) > 0.0;
  return true;
}

template <int Nn, MembraneLaw Law>
[[nodiscard]] inline double element_energy(const Law& law, const ElementNodes<Nn>& x,
                                           const ShapeDerivatives<Nn>* d, const ReferencePoint* ref,
                                           int nq, ElementStatus& status) noexcept {
  const Eigen::Vector3d chord = chord_normal<Nn>(x);
  double e = 0.0;
  for (int q = 0; q < nq; ++q) {
    const auto k = point_kinematics<Nn>(x, derivatives_at<Nn>(d, q), ref[q]);
    status.ok = status.ok && acceptable<Nn>(k, chord);
    e += ref[q].w_da * law.energy(k.tr, k.det);
  }
  return e;
}

// Writes the element's nodal forces into f (overwritten) and returns its energy.
template <int Nn, MembraneLaw Law>
[[nodiscard]] inline double element_forces(const Law& law, const ElementNodes<Nn>& x,
                                           const ShapeDerivatives<Nn>* d, const ReferencePoint* ref,
                                           int nq, std::array<Eigen::Vector3d, Nn>& f,
                                           ElementStatus& status) noexcept {
  for (auto& fi : f) fi.setZero();
  const Eigen::Vector3d chord = chord_normal<Nn>(x);
  double e = 0.0;
  for (int q = 0; q < nq; ++q) {
    const ReferencePoint& r = ref[q];
    const ShapeDerivatives<Nn>& dq = derivatives_at<Nn>(d, q);
    const auto k = point_kinematics<Nn>(x, dq, r);
    status.ok = status.ok && acceptable<Nn>(k, chord);
    e += r.w_da * law.energy(k.tr, k.det);
    const auto [w_tr, w_det] = law.derivatives(k.tr, k.det);
    // -w_da * S^ab, the adjugate of g_ab being (g22, -g12, g11).
    const double s = -2.0 * r.w_da;
    const double s11 = s * (w_tr * r.gi11 + w_det * k.g22 * r.inv_det_g);
    const double s12 = s * (w_tr * r.gi12 - w_det * k.g12 * r.inv_det_g);
    const double s22 = s * (w_tr * r.gi22 + w_det * k.g11 * r.inv_det_g);
    const Eigen::Vector3d t1 = s11 * k.g.g1 + s12 * k.g.g2;  // -w_da S^{a1} g_a
    const Eigen::Vector3d t2 = s12 * k.g.g1 + s22 * k.g.g2;  // -w_da S^{a2} g_a
    for (int i = 0; i < Nn; ++i) f[i] += dq[0][i] * t1 + dq[1][i] * t2;
  }
  return e;
}

}  // namespace capsflow::membrane
