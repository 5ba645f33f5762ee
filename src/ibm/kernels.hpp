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
};

struct HatKernel {
  static constexpr int kSupport = 2;
  static constexpr std::string_view kName = "hat";
  static double weight(double s) {
    const double a = std::abs(s);
    return a < 1.0 ? 1.0 - a : 0.0;
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
};

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

[[nodiscard]] inline int support_of(KernelKind kind) {
  return with_kernel(kind, []<Kernel K>(K) { return K::kSupport; });
}

[[nodiscard]] inline std::string_view name_of(KernelKind kind) {
  return with_kernel(kind, []<Kernel K>(K) { return K::kName; });
}

}  // namespace capsflow::ibm
