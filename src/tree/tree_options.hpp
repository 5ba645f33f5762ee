#pragma once
// What a forest is made of: a brick of root cubes, its periodicity, and its level range.
#include <array>

#include "tree/geometry.hpp"

namespace capsflow::tree {

template <int D>
struct TreeOptions {
  std::array<int, D> roots{};     // root cubes along each direction (each >= 1)
  double root_size = 1.0;         // side of one root cube (> 0)
  Point<D> origin{};              // lower corner of the brick
  std::array<bool, D> periodic{};  // periodic directions wrap, the others have walls
  int max_level = 10;             // deepest level a leaf may reach
};

// Throws std::invalid_argument naming the offending value when the options cannot make a
// forest: a non-positive root count or size, a negative max level, or a max level whose
// coordinates no longer fit in the 64-bit Morton keys or the 32-bit cell indices.
template <int D>
void validate(const TreeOptions<D>& options);

}  // namespace capsflow::tree
