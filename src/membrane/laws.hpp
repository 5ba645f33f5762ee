#pragma once
// Hyperelastic membrane laws: strain energy per unit reference area W as a function of the
// two invariants of the surface right Cauchy-Green tensor C (2x2, mixed components
// C^a_b = G^ac g_cb in the covariant bases of the reference and current surfaces):
//   tr C = lambda1^2 + lambda2^2,  det C = lambda1^2 lambda2^2 = J^2.
// A law is a small type with energy(tr, det), derivatives(tr, det) = (dW/dtr, dW/ddet) and
// second_derivatives(tr, det); everything else (nodal forces, tensions, stiffness) is
// written once for any such type.
//
// Second Piola-Kirchhoff tension S = 2 dW/dC = 2 (W_tr G^-1 + W_det det(C) C^-1), and the
// principal Cauchy tensions (force per deformed length), for principal stretches l1, l2:
//   T1 = (1/l2) dW/dl1 = 2 (l1/l2) (W_tr + W_det l2^2),  T2 likewise with 1 <-> 2.
// Skalak (Skalak et al. 1973), I1 = tr C - 2, I2 = det C - 1:
//   W = (Gs/4) (I1^2 + 2 I1 - 2 I2 + C I2^2)
//   => T1 = Gs (l1/l2) [l1^2 - 1 + C l2^2 (l1^2 l2^2 - 1)].
// Neo-Hookean (thin incompressible sheet): W = (Gs/2) (tr C + 1/det C - 3)
//   => T1 = Gs / (l1 l2) [l1^2 - 1/(l1 l2)^2].
#include <algorithm>
#include <cmath>
#include <concepts>
#include <sstream>
#include <stdexcept>
#include <variant>

namespace capsflow::membrane {

struct InvariantDerivatives {
  double w_tr;   // dW / d(tr C)
  double w_det;  // dW / d(det C)
};

// The second derivatives, for the membrane's tangent stiffness (stiffness_kernel.hpp).
struct InvariantSecondDerivatives {
  double w_tr_tr;    // d2W / d(tr C)^2
  double w_tr_det;   // d2W / d(tr C) d(det C)
  double w_det_det;  // d2W / d(det C)^2
};

struct Skalak {
  double gs = 1.0;  // surface shear modulus
  double c = 1.0;   // area dilatation parameter: Ks = Gs (1 + 2C)

  [[nodiscard]] double energy(double tr, double det) const noexcept {
    const double i1 = tr - 2.0, i2 = det - 1.0;
    return 0.25 * gs * (i1 * i1 + 2.0 * i1 - 2.0 * i2 + c * i2 * i2);
  }
  [[nodiscard]] InvariantDerivatives derivatives(double tr, double det) const noexcept {
    return {0.5 * gs * (tr - 1.0), 0.5 * gs * (c * (det - 1.0) - 1.0)};
  }
  [[nodiscard]] InvariantSecondDerivatives second_derivatives(double /*tr*/, double /*det*/) const noexcept {
    return {0.5 * gs, 0.0, 0.5 * gs * c};
  }
};

struct NeoHookean {
  double gs = 1.0;  // surface shear modulus (Ks = 3 Gs)

  [[nodiscard]] double energy(double tr, double det) const noexcept {
    return 0.5 * gs * (tr + 1.0 / det - 3.0);
  }
  [[nodiscard]] InvariantDerivatives derivatives(double /*tr*/, double det) const noexcept {
    return {0.5 * gs, -0.5 * gs / (det * det)};
  }
  [[nodiscard]] InvariantSecondDerivatives second_derivatives(double /*tr*/, double det) const noexcept {
    return {0.0, 0.0, gs / (det * det * det)};
  }
};

template <class L>
concept MembraneLaw = requires(const L& law, double a, double b) {
  { law.energy(a, b) } -> std::convertible_to<double>;
  { law.derivatives(a, b) } -> std::same_as<InvariantDerivatives>;
  { law.second_derivatives(a, b) } -> std::same_as<InvariantSecondDerivatives>;
};

// Adding a law: a type above, an enumerator here and an alternative in AnyLaw.
enum class LawKind { skalak, neo_hookean };
using AnyLaw = std::variant<Skalak, NeoHookean>;

struct LawParameters {
  LawKind kind = LawKind::skalak;
  double gs = 1.0;
  double c = 1.0;  // Skalak only
};

namespace detail {
inline void require_positive_modulus(const char* law, double gs) {
  if (!(gs > 0.0) || !std::isfinite(gs)) {
    std::ostringstream msg;
    msg << law << " law: shear modulus Gs = " << gs << " must be positive and finite";
    throw std::invalid_argument(msg.str());
  }
}
}  // namespace detail

inline void validate(const Skalak& law) {
  detail::require_positive_modulus("Skalak", law.gs);
  // Ks = Gs (1 + 2C) > 0 keeps the law stable under area dilatation.
  if (!(law.c > -0.5) || !std::isfinite(law.c)) {
    std::ostringstream msg;
    msg << "Skalak law: C = " << law.c << " must be finite and > -1/2 (Ks = Gs (1 + 2C) > 0)";
    throw std::invalid_argument(msg.str());
  }
}
inline void validate(const NeoHookean& law) { detail::require_positive_modulus("neo-Hookean", law.gs); }

// The one place a runtime law choice becomes a type; validates the parameters.
[[nodiscard]] inline AnyLaw make_law(const LawParameters& p) {
  // A switch without default: -Wswitch flags a new LawKind left out here.
  AnyLaw law;
  switch (p.kind) {
    case LawKind::skalak: law = Skalak{p.gs, p.c}; break;
    case LawKind::neo_hookean: law = NeoHookean{p.gs}; break;
  }
  std::visit([](const auto& l) { validate(l); }, law);
  return law;
}

struct PrincipalTensions {
  double lambda1;  // major principal stretch
  double lambda2;  // minor principal stretch
  double t1;       // Cauchy tension along lambda1 (force per deformed length)
  double t2;
};

template <MembraneLaw Law>
[[nodiscard]] PrincipalTensions tensions_from_stretches(const Law& law, double l1, double l2) {
  const auto d = law.derivatives(l1 * l1 + l2 * l2, l1 * l1 * l2 * l2);
  return {l1, l2, 2.0 * (l1 / l2) * (d.w_tr + d.w_det * l2 * l2),
          2.0 * (l2 / l1) * (d.w_tr + d.w_det * l1 * l1)};
}

// From the mixed components C^a_b of C (closed-form eigenvalues of a 2x2 tensor; output
// only). The discriminant is formed from the components, not from tr^2/4 - det, which would
// lose half the digits when lambda1 ~ lambda2.
template <MembraneLaw Law>
[[nodiscard]] PrincipalTensions tensions_from_mixed(const Law& law, double c11, double c12, double c21,
                                                    double c22) {
  const double half_difference = 0.5 * (c11 - c22);
  const double disc = std::sqrt(std::max(0.0, half_difference * half_difference + c12 * c21));
  const double l1sq = 0.5 * (c11 + c22) + disc;
  const double l2sq = (c11 * c22 - c12 * c21) / l1sq;  // det / l1^2, free of cancellation
  return tensions_from_stretches(law, std::sqrt(l1sq), std::sqrt(l2sq));
}

}  // namespace capsflow::membrane
