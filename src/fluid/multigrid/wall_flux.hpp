#pragma once
// The flux through embedded walls (issue "Walls of any shape") for the elliptic operator
// div(alpha grad a) + lambda a, where a = a_wall on the wall (no slip: the wall's velocity).
//
// On a cut cell c (fluid fractions: fluid/embedded_geometry.hpp) the operator is the
// finite-volume balance of its fluid part per unit of the whole cell's volume h^D:
//   L(a)_c = [ sum_k fs_k alpha_k (a_nk - a_c) h^(D-2) + alpha_c grad a(x_w) . N ] / h^D
//            + lambda_c a_c,
// the faces weighted by their fluid fractions fs (the operator's face coefficients), N the
// wall's area vector (the integral of the normal into the solid) and x_w its centroid. The
// gradient at x_w is the least-squares fit of a_wall + g . (x - x_w) to the cell values of
// c's 3^D block of the same level that have fluid, the nearer to the wall the heavier
// (weights 1 / (d^2 + 0.03), d the distance from the wall plane in cells; Johansen &
// Colella 1998 fit the same
// gradient along the normal; Basilisk's embed.h interpolates along it): exact for linear a,
// so with N the faces' imbalance (the divergence theorem) every cut cell's fluxes add up for
// linear fields, and second order overall. A wall along a grid axis whose centroid lies on
// the line of the cell's centre (a channel's planar walls) is fitted on that line only: the
// cell and its neighbour into the fluid, or where the wall is a face of the cell (its centre
// half a cell away) the cell alone, (a_wall - a_c) / (h/2) as at the brick's own walls (the
// fit with the neighbour weakened the row's diagonal and slowed the multigrid). The fit is
// a fixed linear stencil per cut cell,
// built once per geometry: grad a(x_w) . N = sum_k w_k (a_k - a_wall).
//
// The values are read at the cells' centres, also where a centre lies in the solid (the
// smooth extension of the field, as in Basilisk and Johansen & Colella); cells without fluid
// are left out. A cut leaf reads leaves only (a parent or a halo cell of its level holds no
// current value during a residual); a cut parent, on a coarse level of the multigrid, reads
// the active cells of that level.
#include <cstdint>
#include <span>
#include <vector>

#include "fluid/embedded_geometry.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

template <int D>
class WallFlux {
 public:
  // Whether to list the band near the walls that MultigridOptions::wall_band_passes relaxes
  // again (the Navier-Stokes solver's viscous solves take no band passes: it skips the
  // sorting, a tenth of an adaptation's rebuild).
  enum class Band { listed, none };

  // The stencils of every cut active cell of t (every level).
  WallFlux(const tree::Tree<D>& t, const EmbeddedGeometry<D>& geometry, Band band = Band::listed);

  // Whether cell c has a wall stencil.
  bool cut(Index c) const { return row_[static_cast<std::size_t>(c)] >= 0; }
  // grad a(x_w) . N / h^D at cut cell c, split as self * a_c + others(a) + wall * a_wall.
  double self(Index c) const { return self_[static_cast<std::size_t>(row_[static_cast<std::size_t>(c)])]; }
  double others(Index c, std::span<const double> a) const {
    const auto r = static_cast<std::size_t>(row_[static_cast<std::size_t>(c)]);
    double sum = 0.0;
    for (std::int32_t k = start_[r]; k < start_[r + 1]; ++k) sum += weight_[static_cast<std::size_t>(k)] * a[cell_[static_cast<std::size_t>(k)]];
    return sum;
  }
  double wall(Index c) const { return wall_[static_cast<std::size_t>(row_[static_cast<std::size_t>(c)])]; }
  // The whole of it with the wall's value a_wall: grad a(x_w) . N / h^D.
  double flux(Index c, std::span<const double> a, double a_wall) const {
    return self(c) * a[c] + others(c, a) + wall(c) * a_wall;
  }
  // The cut cells of level l (every active one with a wall).
  std::span<const Index> cut_cells(int l) const { return cut_cells_[static_cast<std::size_t>(l)]; }
  // Whether cut cell c's stencil reads a cell of c's own red-black colour: a smoother's pass
  // then takes that part at the values from before the pass (lagged), as those cells change
  // during it. A stencil of the other colour only (a wall on a face, fitted on the column
  // into the fluid) is read as the pass goes: those cells do not change in it.
  bool lagged(Index c) const { return lagged_[static_cast<std::size_t>(row_[static_cast<std::size_t>(c)])] != 0; }
  // The lagged cut cells of level l and one colour (a smoother's pass needs its own colour's only).
  std::span<const Index> lagged_cells(int l, int colour) const { return lagged_by_colour_[static_cast<std::size_t>(2 * l + colour)]; }
  // The active cells of level l with fluid within the 3^D block of a cut cell, of one
  // red-black colour: where the walls' stencils make the smoothing slow, relaxed again.
  std::span<const Index> band(int l, int colour) const { return band_[static_cast<std::size_t>(2 * l + colour)]; }
  bool has_band() const { return has_band_; }
  // Cut cells whose block had too few cells with fluid for a gradient: they fall back to the
  // one-sided difference a_c - a_wall over the distance from the centre to the wall plane
  // (at least h/2). None in a geometry resolved by a few cells.
  std::int64_t fallbacks() const { return fallbacks_; }
  // Cut cells whose wall lies along a grid axis, on the line of their centre: their fit
  // takes the cells on that line only (wall_flux.cpp, normal_column).
  std::int64_t columns() const { return columns_; }

  // A wall on a face of a full cell (EmbeddedGeometry's kStencilClosedFace): its stencil is
  // the same at every such cell and level, the brick's wall gradient from the cell alone,
  // face_column_self() * a_c in units of 1/h^2.
  static double face_column_self();
  // Whether c is a closed-face cell whose stencil is face_column_self()'s (to rounding): the
  // smoother takes it from there, without reading the stencil.
  bool face_column(Index c) const { return face_column_[static_cast<std::size_t>(c)] != 0; }

 private:
  std::vector<std::int32_t> row_;  // per cell slot: its stencil, or -1
  std::vector<std::int32_t> start_;
  std::vector<Index> cell_;
  std::vector<double> weight_, self_, wall_;
  std::vector<std::uint8_t> lagged_;       // per stencil
  std::vector<std::uint8_t> face_column_;  // per cell slot
  std::vector<std::vector<Index>> cut_cells_;
  std::vector<std::vector<Index>> lagged_by_colour_;
  std::vector<std::vector<Index>> band_;
  bool has_band_ = false;
  std::int64_t fallbacks_ = 0;
  std::int64_t columns_ = 0;
};

// The operator's view of the walls: no walls (the brick only; nothing is read).
struct NoWalls {
  static constexpr bool kActive = false;
};

// The walls of a WallFlux with the coefficient alpha at the wall (mu for the viscous
// operator), constant here.
template <int D>
struct WallTerms {
  static constexpr bool kActive = true;
  const WallFlux<D>* flux = nullptr;
  double alpha = 1.0;
  const double* cell_alpha = nullptr;  // per cell slot (a viscosity that varies), else alpha
  bool cut(Index c) const { return flux->cut(c); }
  double at(Index c) const { return cell_alpha ? cell_alpha[c] : alpha; }
  double self(Index c) const { return at(c) * flux->self(c); }
  double others(Index c, std::span<const double> a) const { return at(c) * flux->others(c, a); }
  // The part of L(a)_c that the walls add (homogeneous: a_wall is the right-hand side's).
  double term(Index c, std::span<const double> a) const { return self(c) * a[c] + others(c, a); }
};

extern template class WallFlux<2>;
extern template class WallFlux<3>;

}  // namespace capsflow::fluid
