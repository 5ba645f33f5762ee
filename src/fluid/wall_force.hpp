#pragma once
// The force of the flow on the embedded walls (issue "Walls of any shape": drag and lift),
// summed over the cut leaves from what the solver uses there: each cut cell's pressure on its
// wall's area vector N (the integral of the normal into the solid) and the viscous flux of
// the walls' stencils (multigrid/wall_flux.hpp), mu grad u(x_w) . N with the wall's velocity:
//   F = sum_c ( p_c N_c - mu grad u(x_w) . N_c ).
// The pressure is the cell's centre value (first order in the wall's position). Collective on
// N ranks (owned leaves, summed exactly).
#include <array>

#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {

template <int D>
[[nodiscard]] std::array<double, D> wall_force(NavierStokes<D>& ns);

}  // namespace capsflow::fluid
