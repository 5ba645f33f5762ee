#pragma once
// A stable least-significant-digit radix sort for the plan's large key lists (docs/parallel.md:
// cell keys and curve positions use few of their 64 bits, so two or three passes of 11 bits
// replace a comparison sort that was a tenth of a rank's time on the seed case).
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <utility>
#include <vector>

#include "tree/curve_stencil.hpp"

namespace capsflow::tree {

// Sorts v by key_of(x), an unsigned 64-bit integer, keeping the order of equal keys: one
// counting pass per 11-bit digit of the largest key.
template <class T, class KeyOf>
void radix_sort(std::vector<T>& v, KeyOf key_of) {
  constexpr int kBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  std::uint64_t largest = 0;
  for (const T& x : v) largest = std::max<std::uint64_t>(largest, key_of(x));
  const int bits = static_cast<int>(std::bit_width(largest));
  if (v.size() < 2 || bits == 0) return;
  std::vector<T> scratch(v.size());
  std::array<std::size_t, kBuckets> start{};
  for (int shift = 0; shift < bits; shift += kBits) {
    start.fill(0);
    for (const T& x : v) ++start[(key_of(x) >> shift) & (kBuckets - 1)];
    std::size_t sum = 0;
    for (std::size_t& s : start) sum += std::exchange(s, sum);
    for (const T& x : v) scratch[start[(key_of(x) >> shift) & (kBuckets - 1)]++] = x;
    v.swap(scratch);
  }
}

// v in curve order (curve_less) of cell(x): by level, then stably by position.
template <class T, class CellOf>
void sort_in_curve_order(std::vector<T>& v, CellOf cell) {
  radix_sort(v, [&](const T& x) { return static_cast<std::uint64_t>(cell(x).level); });
  radix_sort(v, [&](const T& x) { return static_cast<std::uint64_t>(cell(x).position); });
}
inline void sort_in_curve_order(std::vector<CurveCell>& v) {
  sort_in_curve_order(v, [](const CurveCell& c) -> const CurveCell& { return c; });
}

}  // namespace capsflow::tree
