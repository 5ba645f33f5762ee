// The viscous and projection stages of a step, with the pressure made consistent with the
// velocity first (FlowOptions::pressure_iterations).
//
// A BDF2 step starts its viscous solve from the pressure p^n and projects an increment phi.
// The step's pressure is consistent when phi = 0: then the viscous solution is itself
// divergence-free on the faces, as in a coupled (Stokes) solve. One projection gets there
// only for the modes whose viscous time rho / (mu k^2) is longer than the step; above it the
// pressure lags (the incremental projection's splitting error). phi(p^n + q) is affine in q,
// and GMRES finds the q that zeroes it: each product is one pass (viscous solves and a
// projection) from the step's start with the pressure p^n + s v, against the first pass; the
// projection is thereby its own preconditioner. Whole passes keep every operator as it is:
// embedded walls, variable properties, N ranks.
//
// Measured on the quick relaxation from t = 1 to 4 at dt = 0.5 (docs/numerics.md): D12 at
// t = 4 went from 0.0484 (one projection) to 0.0179 with 5 iterations, against 0.0185 at
// dt = 0.01. The Cahouet-Chabard form of the preconditioner (phi - mu div u*) converged
// more slowly here; the collocated cell velocity is far from divergence-free at the grid scale.
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <vector>

#include "common/gmres.hpp"
#include "fluid/navier_stokes.hpp"
#include "parallel/exact_sum.hpp"

namespace capsflow::fluid {

namespace {

// GMRES stops at this fraction of the first pass's increment (or at the iteration cap): the
// increment's grid-scale part converges slowly and barely moves the velocity (measured at
// dt = 0.5: 20 iterations still left 5e-3 of it, while D12 after 5 iterations was within
// 2e-4 of 10 iterations').
constexpr double kPressureTolerance = 1e-2;

// A step iterates only where its viscous length sqrt(nu dt) exceeds this many of the finest
// cells: below, every mode that lags is narrower than two cells, under the immersed
// boundary's kernels, and the iterations bought nothing but passes (the seed case's first
// steps, dt = 1.3e-3 at dx = 1/32: 3.3 times the cycles; docs/numerics.md).
constexpr double kLaggingCells = 2.0;

}  // namespace

template <int D>
void NavierStokes<D>::viscous_and_projection_stages(double h, StepStats& stats) {
  // h is the stages' backward-Euler step (b dt, FlowOptions::bdf2); the finest cells the
  // tree may hold, one number on every rank.
  const double finest = tree_.cell_size(tree_.max_level());
  const double nu = properties_ ? nu_max_ : mu_ / options_.density;
  const bool lags = nu * h > kLaggingCells * kLaggingCells * finest * finest;
  if (options_.pressure_iterations == 0 || !lags) {
    viscosity(h, stats);
    acceleration(h);
    projection(h, stats);
    return;
  }
  // The step's start: u^ and p^n (every slot: halos as the stages before left them), and its
  // force as step() evaluated it (BDF2 takes it in the viscous solve), not spread again.
  std::array<std::vector<double>, D> start;
  for (int d = 0; d < D; ++d) start[d].assign(tree_.values(u_[d]).begin(), tree_.values(u_[d]).end());
  const std::span<double> p = tree_.values(p_);
  const std::vector<double> p0(p.begin(), p.end());
  const FaceField<D> force = force_;
  struct Fixed {  // back to the callback when the stages end, by a throw too
    const FaceField<D>*& slot;
    ~Fixed() { slot = nullptr; }
  } fixed{fixed_force_};
  fixed_force_ = face_force_ ? &force : nullptr;
  const std::vector<Index> leaves(tree_.owned_leaves().begin(), tree_.owned_leaves().end());
  const auto n = static_cast<Eigen::Index>(leaves.size());

  // The stages from the start with the pressure p^n + offset (owned leaves).
  const auto start_with = [&](const Eigen::VectorXd& offset) {
    for (int d = 0; d < D; ++d) std::ranges::copy(start[d], tree_.values(u_[d]).begin());
    std::ranges::copy(p0, p.begin());
    for (Eigen::Index k = 0; k < n; ++k) p[leaves[static_cast<std::size_t>(k)]] += offset[k];
    tree_.sync(p, conditions_.pressure, tree::Prolongation::quadratic);
    evaluate_force();
    centred_gradient(h, /*only_g=*/true);
    viscosity(h, stats);
    acceleration(h);
  };
  // One pass: the increment the projection would add.
  const auto pass = [&](const Eigen::VectorXd& offset) {
    start_with(offset);
    std::ranges::fill(tree_.values(dp_), 0.0);
    stats.projection_cycles += project(uf_, dp_, h, options_.projection, stats);
    ++stats.pressure_passes;
    const std::span<const double> increment = tree_.values(dp_);
    Eigen::VectorXd z(n);
    for (Eigen::Index k = 0; k < n; ++k) z[k] = increment[leaves[static_cast<std::size_t>(k)]];
    return z;
  };
  // Summed term by term, exactly: the same on any number of ranks.
  const auto dot = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    parallel::ExactSum sum;
    for (Eigen::Index k = 0; k < n; ++k) sum.add(a[k] * b[k]);
    return tree_.global_sum(sum);
  };
  const auto global_max = [&](const Eigen::VectorXd& v) { return tree_.global_max(n > 0 ? v.cwiseAbs().maxCoeff() : 0.0); };

  const Eigen::VectorXd first = pass(Eigen::VectorXd::Zero(n));
  // The solves stop at absolute tolerances: each product's offset is scaled to the pressure's
  // own size (ten times the first increment when the pressure is still zero).
  double p_max = 0.0;
  for (const Index c : leaves) p_max = std::max(p_max, std::abs(p0[static_cast<std::size_t>(c)]));
  p_max = tree_.global_max(p_max);
  const double scale = p_max > 0.0 ? p_max : 10.0 * global_max(first);
  Eigen::VectorXd offset;
  if (scale > 0.0) {
    const auto apply = [&](const Eigen::VectorXd& v) {
      const double s = scale / global_max(v);
      return Eigen::VectorXd((first - pass(s * v)) / s);
    };
    const auto identity = [](const Eigen::VectorXd& v) { return v; };
    // The cap is a budget, not a failure: the step's own projection below takes what the
    // iterations left, as a step without them takes all of it.
    const GmresResult solved = fgmres(apply, identity, dot, first, offset, kPressureTolerance, options_.pressure_iterations);
    stats.pressure_residual = solved.residual;
  } else {
    offset = Eigen::VectorXd::Zero(n);  // a flow at rest without force: nothing to iterate
  }
  // The step, from p^n + offset: its projection adds what is left.
  start_with(offset);
  projection(h, stats);
}

template void NavierStokes<2>::viscous_and_projection_stages(double, StepStats&);
template void NavierStokes<3>::viscous_and_projection_stages(double, StepStats&);

}  // namespace capsflow::fluid
