#pragma once
// Options and statistics of the multigrid solver (plain values; the caller decides what a
// failure to converge means).
#include <cmath>
#include <limits>
#include <vector>

namespace capsflow::fluid {

enum class Smoother { red_black, jacobi };

// |x|, but +infinity for a NaN: the maximum of a residual must not drop a NaN (std::max
// and the OpenMP max reduction ignore one that comes second), else a solve fed NaN
// reports a finite residual, even convergence.
inline double abs_or_infinity(double x) {
  const double r = std::abs(x);
  return r <= std::numeric_limits<double>::max() ? r : std::numeric_limits<double>::infinity();
}

struct MultigridOptions {
  double tolerance = 1e-3;  // on max |b - L(a)| over the leaves (Basilisk's default)
  int min_cycles = 1;
  int max_cycles = 100;
  int relax_sweeps = 4;       // smoothing sweeps per level and cycle
  int coarsest_sweeps = 32;   // on level 0, where a few roots are nearly solved exactly
  Smoother smoother = Smoother::red_black;
  double jacobi_weight = 0.8;
  bool warm_start = true;     // start from the values in `a` (else from zero)
  // Use each cycle as the preconditioner of a flexible conjugate gradient (Notay 2000)
  // instead of iterating cycles alone: robust to large coefficient jumps (a 1000x density
  // or viscosity ratio), where coarse levels misrepresent the operator.
  bool krylov = false;
  // Plain cycles until one of them makes the residual grow, then the Krylov iteration from
  // there (MultigridStats::switched_to_krylov): for operators whose coarse levels may
  // misrepresent them somewhere (embedded walls whose cut cells crowd a coarse cell), at no
  // cost where the cycles converge.
  bool krylov_on_growth = false;
  // Red-black passes over the cells near embedded walls before each sweep
  // (WallFlux::band): the walls' stencils reach past the face neighbours and smooth slowly
  // where nothing else holds the cells (a Poisson operator: pipe, 256^2, 27 cycles without
  // them, 13 with). A Helmholtz operator's cell term holds them: the viscous solves take 0
  // (docs/walls.md, "Cost").
  int wall_band_passes = 2;
};

struct [[nodiscard]] MultigridStats {
  int cycles = 0;
  double initial_residual = 0.0;
  double final_residual = 0.0;
  bool converged = false;
  std::vector<double> residuals;  // max |residual| before the first cycle and after each
  bool switched_to_krylov = false;  // krylov_on_growth took effect

  // Geometric mean of the residual reduction over the first `n` cycles.
  double mean_reduction(int n) const;
};

}  // namespace capsflow::fluid
