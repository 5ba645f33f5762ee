#pragma once
// Boundary conditions of a cell field on the non-periodic sides of the brick.
//
// They act through boundary cells (tree.hpp): a boundary cell b outside side s takes its
// value from its source cell c (one cell inward across s, of the same level):
//   Dirichlet u = g(x_b):       u_b = 2 g(x_b) - u_c
//   Neumann   du/dn = g(x_b):   u_b = u_c + h g(x_b)          (n the outward normal)
// where x_b is the midpoint of the two centres, on the boundary. Both are exact for linear
// fields. Edge and corner boundary cells are filled after those they take their source from,
// by the same rule applied across one of their sides, which keeps linear fields exact there.
#include <array>
#include <functional>
#include <stdexcept>
#include <string>

#include "tree/geometry.hpp"

namespace capsflow::tree {

enum class BcKind : unsigned char { dirichlet, neumann };

template <int D>
struct SideCondition {
  BcKind kind = BcKind::neumann;
  double value = 0.0;                                // used when `function` is empty
  std::function<double(const Point<D>&)> function;  // value at a boundary point

  double at(const Point<D>& x) const { return function ? function(x) : value; }
  bool homogeneous() const { return !function && value == 0.0; }
};

// Sides are numbered 2d (low side of direction d) and 2d+1 (high side).
template <int D>
struct BoundaryConditions {
  std::array<SideCondition<D>, 2 * D> side{};

  static BoundaryConditions all(BcKind kind, double value = 0.0) {
    BoundaryConditions bc;
    for (auto& s : bc.side) s = SideCondition<D>{kind, value, {}};
    return bc;
  }
  // Same kinds, zero values: the conditions an error or a correction satisfies.
  BoundaryConditions homogeneous() const {
    BoundaryConditions bc;
    for (int s = 0; s < 2 * D; ++s) bc.side[s].kind = side[s].kind;
    return bc;
  }
};

}  // namespace capsflow::tree
