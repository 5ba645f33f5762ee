#pragma once
// The 3^D - 1 neighbour slots of a cell, as compile-time tables.
//
// Slot order: the 2D face neighbours first (slot 2d is -e_d, slot 2d+1 is +e_d), then the
// edge and corner neighbours in lexicographic order of their offsets. Face-only stencils
// (the 5/7-point Laplacian) thus read a dense face table; 3^D stencils read both tables.
#include <array>
#include <cstdlib>

namespace capsflow::tree {

constexpr int ipow(int base, int exp) { return exp == 0 ? 1 : base * ipow(base, exp - 1); }

template <int D>
inline constexpr int kChildren = 1 << D;
template <int D>
inline constexpr int kFaces = 2 * D;
template <int D>
inline constexpr int kStencil = ipow(3, D) - 1;  // neighbours of a cell in its 3^D block
template <int D>
inline constexpr int kDiagonals = kStencil<D> - kFaces<D>;

template <int D>
using Offset = std::array<int, D>;

namespace detail {

template <int D>
constexpr std::array<Offset<D>, kStencil<D>> make_offsets() {
  std::array<Offset<D>, kStencil<D>> out{};
  int n = 0;
  for (int d = 0; d < D; ++d)
    for (int s = -1; s <= 1; s += 2) {
      Offset<D> o{};
      o[d] = s;
      out[n++] = o;
    }
  for (int code = 0; code < ipow(3, D); ++code) {
    Offset<D> o{};
    int nonzero = 0;
    for (int d = 0, c = code; d < D; ++d, c /= 3) {
      o[d] = c % 3 - 1;
      nonzero += o[d] != 0;
    }
    if (nonzero >= 2) out[n++] = o;
  }
  return out;
}

}  // namespace detail

// kOffsets<D>[slot] is the offset (in cells of the same level) of neighbour `slot`.
template <int D>
inline constexpr std::array<Offset<D>, kStencil<D>> kOffsets = detail::make_offsets<D>();

constexpr int face_slot(int d, int side) { return 2 * d + side; }  // side 0: low, 1: high

// Slot of an offset, or -1 for the zero offset.
template <int D>
constexpr int slot_of(const Offset<D>& o) {
  for (int s = 0; s < kStencil<D>; ++s)
    if (kOffsets<D>[s] == o) return s;
  return -1;
}

}  // namespace capsflow::tree
