#pragma once
// Immersed-boundary delta kernels (STYLE.md rule 7): a kernel is a type with its support
// width W (in cells) and its 1D weight phi(s), s = (x_cell - X) / dx; the 3D weight is the
// product phi(sx) phi(sy) phi(sz). Spreading and interpolation (spread.hpp,
// interpolate.hpp) are templates over such a type.
//
//   cosine  (seed paper eq. 5, Peskin 2002):  phi(s) = (1 + cos(pi s / 2)) / 4,  |s| <= 2
//   hat     (seed paper eq. 7):                phi(s) = 1 - |s|,                 |s| <= 1
//   Peskin 4-point (Peskin 2002, eq. 6.27):
//           phi(s) = (3 - 2|s| + sqrt(1 + 4|s| - 4 s^2)) / 8,   |s| <= 1
//                    (5 - 2|s| - sqrt(-7 + 12|s| - 4 s^2)) / 8,  1 <= |s| <= 2
//
// Discrete moments over the W cells of a stencil, s_k = (x_cell - X)/dx and r in [0, 1) the
// node's offset from the nearest lower cell centre, in cells (stencil.hpp):
//   sum phi = 1 for all three (the cosine's four cos terms cancel in pairs);
//   sum s phi = 0 for hat and Peskin, but for the cosine kernel it is
//       m(r) = 1/2 - r + (sin(pi r/2) - cos(pi r/2)) / 2,   |m| <= 0.0211,
//   zero only for r in {0, 1/2}: the seed's cosine kernel conserves the total force
//   exactly but moves each point force's line of action by dx m(r) per axis, so the
//   total torque is conserved only up to sum_X dx m(X) x F(X); it interpolates linear
//   fields exactly only at those offsets (tests/ibm check both statements);
//   sum phi^2 = 3/8 for cosine and Peskin at every r (hat: (1-r)^2 + r^2).
//
// Each kernel also gives its cumulative integral C(t) = integral of phi from -inf to t (in
// cells), from which DivergenceFree<K> (below) builds the smoothed kernel phi * box.
#include <algorithm>
#include <cmath>
#include <concepts>
#include <numbers>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

namespace capsflow::ibm {

template <class K>
concept Kernel = requires(double s) {
  { K::kSupport } -> std::convertible_to<int>;
  { K::weight(s) } -> std::same_as<double>;
} && K::kSupport >= 2 && K::kSupport % 2 == 0;

struct CosineKernel {
  static constexpr int kSupport = 4;
  static constexpr std::string_view kName = "cosine";
  static double weight(double s) {
    const double a = std::abs(s);
    return a < 2.0 ? 0.25 * (1.0 + std::cos(0.5 * std::numbers::pi * a)) : 0.0;
  }
  // Optional batched form (used by stencil.hpp when a kernel has it): the four weights at
  // s_k = k - 1 - r, r in [0, 1). With q = pi r / 2 the cosines are -sin q, cos q, sin q,
  // -cos q: one sine and one cosine instead of four cosines.
  static void stencil_weights(double r, double* w) {
    const double q = 0.5 * std::numbers::pi * r;
    const double sq = std::sin(q), cq = std::cos(q);
    w[0] = 0.25 * (1.0 - sq);
    w[1] = 0.25 * (1.0 + cq);
    w[2] = 0.25 * (1.0 + sq);
    w[3] = 0.25 * (1.0 - cq);
  }
  static double cumulative(double t) {
    const double a = std::min(std::abs(t), 2.0);
    return 0.5 + std::copysign(0.25 * (a + (2.0 / std::numbers::pi) * std::sin(0.5 * std::numbers::pi * a)), t);
  }
  // Optional batched form of DivergenceFree<CosineKernel>'s five weights (stencil.hpp's
  // face_stencil): psi(s_k) = C(a_(k+1)) - C(a_k) at a_k = k - 2 - r, k = 0..5, r in [0, 1).
  // C is 0 at a_0 and 1 at a_5; inside, C(a) = 1/2 + a/4 + sin(pi a / 2) / (2 pi), and with
  // q = pi r / 2 the sines at a_1..a_4 are -cos q, -sin q, cos q, sin q: one sine and one
  // cosine instead of ten sines.
  static void smoothed_stencil_weights(double r, double* w) {
    const double q = 0.5 * std::numbers::pi * r;
    const double sq = std::sin(q), cq = std::cos(q), k = 0.5 / std::numbers::pi;
    const double c1 = 0.5 + 0.25 * (-1.0 - r) - k * cq;
    const double c2 = 0.5 + 0.25 * -r - k * sq;
    const double c3 = 0.5 + 0.25 * (1.0 - r) + k * cq;
    const double c4 = 0.5 + 0.25 * (2.0 - r) + k * sq;
    w[0] = c1;
    w[1] = c2 - c1;
    w[2] = c3 - c2;
    w[3] = c4 - c3;
    w[4] = 1.0 - c4;
  }
};

struct HatKernel {
  static constexpr int kSupport = 2;
  static constexpr std::string_view kName = "hat";
  static double weight(double s) {
    const double a = std::abs(s);
    return a < 1.0 ? 1.0 - a : 0.0;
  }
  static double cumulative(double t) {
    const double a = std::min(std::abs(t), 1.0);
    return 0.5 + std::copysign(a - 0.5 * a * a, t);
  }
};

struct Peskin4Kernel {
  static constexpr int kSupport = 4;
  static constexpr std::string_view kName = "peskin4";
  static double weight(double s) {
    const double a = std::abs(s);
    if (a <= 1.0) return 0.125 * (3.0 - 2.0 * a + std::sqrt(1.0 + 4.0 * a - 4.0 * a * a));
    if (a < 2.0) return 0.125 * (5.0 - 2.0 * a - std::sqrt(std::max(0.0, -7.0 + 12.0 * a - 4.0 * a * a)));
    return 0.0;
  }
  // Both square roots are sqrt(2 - v^2) (v = 2a - 1, then 2a - 3), whose integral over v is
  // F(v) = (v/2) sqrt(2 - v^2) + asin(v / sqrt 2).
  static double cumulative(double t) {
    const double a = std::min(std::abs(t), 2.0);
    const auto f = [](double v) { return 0.5 * v * std::sqrt(std::max(0.0, 2.0 - v * v)) + std::asin(v / std::numbers::sqrt2); };
    const double f1 = f(-1.0);
    double p = 0.0;  // integral of phi over [0, a]
    if (a <= 1.0) {
      p = 0.125 * (3.0 * a - a * a + 0.5 * (f(2.0 * a - 1.0) - f1));
    } else {
      p = 0.125 * (2.5 + 0.25 * std::numbers::pi) +
          0.125 * (5.0 * (a - 1.0) - (a * a - 1.0) - 0.5 * (f(2.0 * a - 3.0) - f1));
    }
    return 0.5 + std::copysign(p, t);
  }
};

// The divergence-free form of kernel K for staggered (MAC) grids (Bao, Donev, Griffith,
// McQueen & Peskin 2017, J. Comput. Phys. 347). Component d of a face field is interpolated
// with K along the two axes normal to d (faces sit at cell centres there) and, along d, with
// the smoothed kernel
//   psi(s) = integral of phi over [s - 1/2, s + 1/2] = C(s + 1/2) - C(s - 1/2)   (phi * box),
// whose support is one cell wider. Then d/dX psi(x_f - X) = phi(x_f - X - 1/2) -
// phi(x_f - X + 1/2), and summation by parts turns the divergence of the interpolated field
// into the K-interpolation of the discrete divergence:
//   div_X V(X) = sum_cells (div_h uf)_c phi(sx) phi(sy) phi(sz) / dx,
// so V is divergence-free wherever uf is (discretely): a closed surface moving with V keeps
// its volume up to the time integration and the surface's own discretisation. Spreading with
// the same weights stays its adjoint. kSupport is K's plus 2 (psi needs W + 1 points, padded
// to an even stencil; the normal axes pad K's weights with a zero on each side: stencil.hpp).
template <class K>
concept SmoothableKernel = Kernel<K> && requires(double t) {
  { K::cumulative(t) } -> std::same_as<double>;
};

template <SmoothableKernel K>
struct DivergenceFree {
  using Base = K;
  static constexpr int kSupport = K::kSupport + 2;
  static constexpr std::string_view kName = K::kName;
  static double weight(double s) { return K::cumulative(s + 0.5) - K::cumulative(s - 0.5); }
};

template <class K>
inline constexpr bool kIsDivergenceFree = false;
template <SmoothableKernel K>
inline constexpr bool kIsDivergenceFree<DivergenceFree<K>> = true;

// The run-time choice (a case file's kernel keys become this once, at parse time).
// Adding a kernel: a type above, an enumerator here, a case in with_kernel, and an
// explicit instantiation in spread.cpp and interpolate.cpp.
enum class KernelKind : unsigned char { cosine, hat, peskin4 };

// Calls f(K{}) with the kernel type of `kind`; f's return type must not depend on K.
template <class F>
decltype(auto) with_kernel(KernelKind kind, F&& f) {
  switch (kind) {
    case KernelKind::cosine: return std::forward<F>(f)(CosineKernel{});
    case KernelKind::hat: return std::forward<F>(f)(HatKernel{});
    case KernelKind::peskin4: return std::forward<F>(f)(Peskin4Kernel{});
  }
  throw std::invalid_argument("ibm: unknown kernel kind " + std::to_string(static_cast<int>(kind)));
}

// Calls f(DivergenceFree<K>{}) when divergence_free, else f(K{}) (face stencils).
template <class F>
decltype(auto) with_face_kernel(KernelKind kind, bool divergence_free, F&& f) {
  return with_kernel(kind, [&]<Kernel K>(K k) -> decltype(auto) {
    if (divergence_free) return f(DivergenceFree<K>{});
    return f(k);
  });
}

[[nodiscard]] inline int support_of(KernelKind kind, bool divergence_free = false) {
  return with_face_kernel(kind, divergence_free, []<Kernel K>(K) { return K::kSupport; });
}

[[nodiscard]] inline std::string_view name_of(KernelKind kind) {
  return with_kernel(kind, []<Kernel K>(K) { return K::kName; });
}

}  // namespace capsflow::ibm
