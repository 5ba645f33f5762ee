#pragma once
// The flow's energy budget (issue 32). The momentum equation dotted with u and integrated
// over the domain Omega (div u = 0, the viscous term as the solver writes it) gives
//   dK/dt = P_f - Phi + P_b,
//   K   = int rho |u|^2 / 2 dV                                       kinetic energy
//   P_f = int f . u dV                                                power of the body force
//   Phi = int mu |grad u|^2 dV + int mu d_i u_j d_j u_i dV            viscous dissipation
//         (the second part is the transpose stress: zero where mu is constant)
//   P_b = int_dOmega ( -p u.n + mu u.(grad u) n - rho |u|^2 / 2 u.n ) dS
//         the work of the sides (moving walls, inflow, outflow), n the outward normal; the
//         last term (the kinetic energy carried across) only with advection.
// Discretely, on the leaves and the fine faces the solver uses (fluid/faces.hpp):
//   K   = sum_leaves rho_c |u_c|^2 / 2 h^D
//   Phi = sum over fine faces (lo, hi) along d of w mu_f sum_k (u_k(hi) - u_k(lo))^2 h^(D-2)
//         with w the length of the face's dual cell (between the two centres) in units of h:
//         1, 1.5 next to a coarser leaf (lo or hi a halo cell: from the coarse centre to the
//         fine one), 1/2 on a side of the brick (hi or lo a boundary cell holding the boundary value,
//         2 g - u for Dirichlet, u + h g for Neumann: the half cell between the centre and the
//         side). The dual cells tile the domain along each d, so Phi is second order on
//         adaptive grids too. On a uniform grid Phi - P_b's viscous part is exactly
//         -sum_c u_c . (div(mu grad u))_c h^D, the solver's own operator; with variable mu,
//         minus sum_c u_c . T_c h^D, T its transpose stress.
//   P_f = sum over fine faces of f_d uf_d h^D, f the solver's face force of the last step
//         and uf the projected face velocity: with the spread force of a membrane this is
//         exactly sum_nodes F . V when spreading and interpolation are adjoint.
//   P_b on each boundary face: the face values u_b = (u_out + u_c)/2, du/dn =
//         (u_out - u_c)/h (outward, u_out the boundary cell's), p_b = 0 where the pressure is Dirichlet (outflow) and
//         p_c where it is Neumann (the solver's homogeneous conditions), and the projected
//         face velocity's outward component for u.n.
// The cell velocity u is the solver's state; the face velocity uf is what the projection
// makes divergence-free and what membranes move with. The two differ by the approximate
// projection's error, so the budget closes up to the scheme's error, not exactly.
// Sums are compensated per thread and rank and added exactly across them: the same on N
// ranks as on one (parallel/compensated_sum.hpp).
#include "fluid/faces.hpp"
#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {

struct FlowEnergy {
  double kinetic = 0.0;         // K
  double dissipation = 0.0;     // Phi
  double boundary_power = 0.0;  // P_b
};

// K, Phi and P_b of the current state of ns (at the end of a step: the pressure and the
// face velocity of its projection). Syncs the velocity (its boundary values at ns.time()).
// Collective on N ranks.
template <int D>
[[nodiscard]] FlowEnergy flow_energy(NavierStokes<D>& ns);

// K alone (no sync: the leaves' values). Collective on N ranks.
template <int D>
[[nodiscard]] double kinetic_energy(const NavierStokes<D>& ns);

// sum over the fine faces of force_d uf_d h^D (both fields spanning the tree), each face
// weighted by its open fraction with embedded walls (open: EmbeddedGeometry::faces(); the
// projection's inner product, which the near-wall coupling keeps adjoint). Collective on N
// ranks.
template <int D>
[[nodiscard]] double face_power(const tree::Tree<D>& t, const FaceField<D>& force, const FaceField<D>& uf,
                                const FaceField<D>* open = nullptr);

}  // namespace capsflow::fluid
