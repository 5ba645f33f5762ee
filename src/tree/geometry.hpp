#pragma once
// Points and axis-aligned boxes in D dimensions.
#include <array>

namespace capsflow::tree {

template <int D>
using Point = std::array<double, D>;

template <int D>
struct Box {
  Point<D> lo{};
  Point<D> hi{};
};

}  // namespace capsflow::tree
