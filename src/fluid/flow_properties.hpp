#pragma once
// Density and viscosity as cell fields (NavierStokes::set_properties; constant by default).
//
// Face coefficients from the cell values (multigrid/coefficients.hpp, face_coefficients):
//   mu_f    = harmonic mean 2 mu_a mu_b / (mu_a + mu_b): the two half cells conduct
//             momentum in series, so the flux mu du/dn is continuous across a face where
//             mu jumps and a piecewise-linear profile with its kink on the face is exact
//             (the arithmetic mean would let the more viscous side dominate);
//   alpha_f = 1 / rho_f, rho_f = (rho_a + rho_b) / 2: the mass of the face's control
//             volume, half from each cell; a face force rho_f g is then an exact discrete
//             gradient for rho = rho(height), balanced by the pressure.
// Properties have zero normal gradient at the domain boundary (a wall face takes its cell's
// value), and a halo cell stands for its coarse leaf.
//
// The transpose part of the stress div(mu (grad u + grad u^T)) is, since div u = 0,
//   T_i = d_j(mu d_i u_j) - mu d_i(div u) = (d_j mu)(d_i u_j),
// discretised at a leaf c of size h (sum over j = 1..D and the two faces of c along j) as
//   T_i = (1/h) sum_j [(mu_{j+} - mu_c) G_ij^{j+} - (mu_{j-} - mu_c) G_ij^{j-}]
// with G_ij = d_i u_j on the face: the normal difference for j = i, the mean of the two
// cells' central differences along i for j != i (all from c's 3^D neighbourhood at its own
// level). It is second order for smooth mu and exactly zero where mu is constant; the
// conservative form d_j(mu d_i u_j) alone would leave mu grad(div u_c) there, since cell
// velocities are only approximately solenoidal. The solver treats T explicitly.
#include <array>
#include <span>
#include <utility>
#include <vector>

#include "fluid/faces.hpp"
#include "fluid/multigrid/coefficients.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

// The coefficient of the fine face (lo, hi) along d (as for_each_face gives it) in an
// array of 2D values per cell: the lower face of hi when hi is active, else the upper
// face of the leaf lo.
template <int D>
double face_coefficient(const tree::Level<D>& lv, const std::vector<double>& coef, int d, Index lo,
                        Index hi) {
  return hi < lv.active_end() ? coef[static_cast<std::size_t>(hi) * (2 * D) + 2 * d]
                              : coef[static_cast<std::size_t>(lo) * (2 * D) + 2 * d + 1];
}

// out = T_i (above) on the leaves. u: the D velocity components, synced (boundary cells, halos and
// parents valid); mu_cells on the leaves; mu_faces from face_coefficients(.., harmonic).
// With `only` (the leaves and their levels where mu varies: varying_viscosity), T_i on those
// leaves alone; it is zero on the others, which are left as they are.
template <int D>
void transpose_stress(const tree::Tree<D>& t, const std::array<std::span<const double>, D>& u,
                      std::span<const double> mu_cells, const std::vector<double>& mu_faces, int i,
                      std::span<double> out, const std::vector<std::pair<Index, int>>* only = nullptr);

// The leaves (with their levels) where a face viscosity differs from the leaf's own: where
// the transpose stress can be non-zero (an inner fluid's membrane band, not the whole flow).
template <int D>
std::vector<std::pair<Index, int>> varying_viscosity(const tree::Tree<D>& t, std::span<const double> mu_cells,
                                                     const std::vector<double>& mu_faces);

}  // namespace capsflow::fluid
