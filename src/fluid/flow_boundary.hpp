#pragma once
// Flow boundary conditions per side of the brick, and what they mean for each field.
//
//   side kind    velocity (boundary cells)                  pressure
//   wall         Dirichlet 0                                Neumann 0
//   moving_wall  Dirichlet: the wall's tangential velocity  Neumann 0
//   inflow       Dirichlet: profile along the normal, 0     Neumann 0
//                tangential
//   outflow      Neumann 0                                  Dirichlet 0
//   prescribed   Dirichlet: a function of (x, component, t)  Neumann 0
//   periodic     (wraps; the tree's side must be periodic)  (wraps)
// The seed channel: walls on the inlet and the four lateral sides, outflow on the outlet.
#include <array>
#include <functional>
#include <string>

#include "tree/boundary.hpp"
#include "tree/tree_options.hpp"

namespace capsflow::fluid {

enum class SideKind { wall, moving_wall, inflow, outflow, periodic, prescribed };
enum class InflowProfile { uniform, parabolic, square_duct, pipe };

template <int D>
struct SideFlow {
  SideKind kind = SideKind::wall;
  std::array<double, D> velocity{};  // moving_wall: the wall velocity (tangential)
  InflowProfile profile = InflowProfile::uniform;
  double mean_velocity = 1.0;  // inflow: mean normal velocity entering the domain
  // pipe: Poiseuille flow 2 U (1 - r^2 / R^2) within r < R of the side's normal through
  // pipe_centre (U the mean over that disc; 0 beyond it), the inflow of a circular tube.
  double pipe_radius = 0.0;
  std::array<double, D> pipe_centre{};
  // prescribed: velocity component `d` at x and time t (exact solutions, general inlets).
  std::function<double(const tree::Point<D>&, int d, double t)> prescribed;
};

template <int D>
struct FlowConditions {
  std::array<tree::BoundaryConditions<D>, D> velocity;
  tree::BoundaryConditions<D> pressure;
};

// Side names as in case files: x_lo, x_hi, y_lo, ...
std::string side_name(int side);

// Checks the sides against the tree (a periodic side must face a periodic one and the
// tree's direction must be periodic; no inflow on a periodic side; a moving wall moves
// tangentially; the square-duct profile is 3D) and builds the field conditions. Throws
// std::invalid_argument naming the side and the reason. Time-dependent conditions read
// the time at *time when they are evaluated.
template <int D>
FlowConditions<D> make_flow_conditions(const std::array<SideFlow<D>, 2 * D>& sides,
                                       const tree::TreeOptions<D>& domain, const double* time);

}  // namespace capsflow::fluid
