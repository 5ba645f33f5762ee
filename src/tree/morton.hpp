#pragma once
// Morton (Z-order) keys of cells on a uniform level of the forest.
//
// A cell of level L is identified by its integer coordinates (i, j[, k]) on the uniform grid
// of level L that covers the whole brick of root cells; its key interleaves the bits of the
// coordinates (bit b of coordinate d goes to bit D*b + d). Consequences used everywhere:
//   child key  = (parent key << D) | child number,   child number = sum_d bit_d << d
//   parent key = key >> D
// so sorting by key puts siblings next to each other and children in their parent's order.
// Keys are 64-bit: 21 bits per coordinate in 3D, 32 in 2D.
//
// The primitives assert (checked builds, common/assert.hpp) what p4est's do: their input is
// a valid key or coordinate and their output one too; a coordinate or child number out of
// range would otherwise be truncated silently into another cell's key.
#include <array>
#include <cstdint>

#include "common/assert.hpp"

namespace capsflow::tree {

using Key = std::uint64_t;

template <int D>
inline constexpr int kKeyBitsPerDim = 64 / D;

namespace detail {

// Spread the low bits of x so that bit b lands at bit D*b.
template <int D>
constexpr std::uint64_t spread_bits(std::uint64_t x) {
  if constexpr (D == 2) {
    x &= 0xffffffffULL;
    x = (x | (x << 16)) & 0x0000ffff0000ffffULL;
    x = (x | (x << 8)) & 0x00ff00ff00ff00ffULL;
    x = (x | (x << 4)) & 0x0f0f0f0f0f0f0f0fULL;
    x = (x | (x << 2)) & 0x3333333333333333ULL;
    x = (x | (x << 1)) & 0x5555555555555555ULL;
  } else {
    static_assert(D == 3, "capsflow trees are 2D or 3D");
    x &= 0x1fffffULL;
    x = (x | (x << 32)) & 0x001f00000000ffffULL;
    x = (x | (x << 16)) & 0x001f0000ff0000ffULL;
    x = (x | (x << 8)) & 0x100f00f00f00f00fULL;
    x = (x | (x << 4)) & 0x10c30c30c30c30c3ULL;
    x = (x | (x << 2)) & 0x1249249249249249ULL;
  }
  return x;
}

// Inverse of spread_bits: gather every D-th bit back into the low bits.
template <int D>
constexpr std::uint64_t gather_bits(std::uint64_t x) {
  if constexpr (D == 2) {
    x &= 0x5555555555555555ULL;
    x = (x | (x >> 1)) & 0x3333333333333333ULL;
    x = (x | (x >> 2)) & 0x0f0f0f0f0f0f0f0fULL;
    x = (x | (x >> 4)) & 0x00ff00ff00ff00ffULL;
    x = (x | (x >> 8)) & 0x0000ffff0000ffffULL;
    x = (x | (x >> 16)) & 0x00000000ffffffffULL;
  } else {
    x &= 0x1249249249249249ULL;
    x = (x | (x >> 2)) & 0x10c30c30c30c30c3ULL;
    x = (x | (x >> 4)) & 0x100f00f00f00f00fULL;
    x = (x | (x >> 8)) & 0x001f0000ff0000ffULL;
    x = (x | (x >> 16)) & 0x001f00000000ffffULL;
    x = (x | (x >> 32)) & 0x1fffffULL;
  }
  return x;
}

}  // namespace detail

template <int D>
using Coords = std::array<std::int32_t, D>;

// Whether a key's coordinates fit their bits: every key fits in 2D; in 3D the top bit is
// never set.
template <int D>
constexpr bool key_in_range(Key k) {
  if constexpr (D * kKeyBitsPerDim<D> == 64) return true;
  else return (k >> (D * kKeyBitsPerDim<D>)) == 0;
}

template <int D>
constexpr bool coords_in_range(const Coords<D>& c) {
  for (int d = 0; d < D; ++d)
    if (c[d] < 0 || c[d] >= (std::int64_t{1} << kKeyBitsPerDim<D>)) return false;
  return true;
}

// Coordinates must be non-negative and fit kKeyBitsPerDim bits (boundary cells outside the brick
// have no keys).
template <int D>
constexpr Key morton_encode(const Coords<D>& c) {
  CAPSFLOW_ASSERT(coords_in_range<D>(c), "morton_encode: a coordinate is negative or wider than a key's bits");
  Key k = 0;
  for (int d = 0; d < D; ++d) k |= detail::spread_bits<D>(static_cast<std::uint32_t>(c[d])) << d;
  return k;
}

template <int D>
constexpr Coords<D> morton_decode(Key k) {
  CAPSFLOW_ASSERT(key_in_range<D>(k), "morton_decode: key has bits above the last coordinate bit");
  Coords<D> c{};
  for (int d = 0; d < D; ++d) c[d] = static_cast<std::int32_t>(detail::gather_bits<D>(k >> d));
  return c;
}

template <int D>
constexpr Key parent_key(Key k) {
  CAPSFLOW_ASSERT(key_in_range<D>(k), "parent_key: key out of range");
  return k >> D;
}

// The parent must have room for one more level (its top D bits clear), or the shift would
// drop them: the child would belong to another root.
template <int D>
constexpr Key child_key(Key parent, int child) {
  CAPSFLOW_ASSERT(child >= 0 && child < (1 << D), "child_key: child number outside [0, 2^D)");
  CAPSFLOW_ASSERT(parent >> (D * kKeyBitsPerDim<D> - D) == 0,
                  "child_key: the parent is at the deepest level a key can hold");
  const Key k = (parent << D) | static_cast<Key>(child);
  CAPSFLOW_ASSERT(key_in_range<D>(k) && parent_key<D>(k) == parent, "child_key: the child key is not valid");
  return k;
}

// Which child of its parent a cell is (the low D bits of its key).
template <int D>
constexpr int child_number(Key k) {
  return static_cast<int>(k & ((Key{1} << D) - 1));
}

// Bit d of a child number: 0 for the lower half along d, 1 for the upper half.
constexpr int child_bit(int child, int d) { return (child >> d) & 1; }

}  // namespace capsflow::tree
