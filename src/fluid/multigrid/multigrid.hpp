#pragma once
// Geometric multigrid on the tree's own levels (Basilisk's multilevel solver, poisson.h):
// one cycle, written once, for any operator with residual(), apply() and relax().
//
// A cycle (vcycle): the residual r = b - L(a) on the leaves is restricted (volume average)
// to every parent; then, from level 0 to the deepest, the correction da of level l starts
// as the prolongation of level l-1's (zero on level 0), its halo is prolonged from the
// coarse leaves, and it is smoothed on the active cells of level l against r. Leaves of
// every level are corrected on their own level; parents stand for the finer cells below.
//
// solve() either iterates cycles (a += da), or, with `krylov`, uses each cycle as the
// preconditioner of a flexible conjugate gradient (FCG(1), Notay 2000): search direction
// p = z + beta p_old made L-conjugate to the previous one, step alpha = <p,r>/<p,Lp>, with
// the volume-weighted inner product over the leaves in which the operator is symmetric.
//
// For a singular problem (pure Neumann/periodic, no lambda) the residual's volume mean is
// removed (compatibility) and the mean of a is fixed to zero.
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <span>
#include <vector>

#include "common/assert.hpp"
#include "fluid/multigrid/multigrid_options.hpp"
#include "parallel/compensated_sum.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

// Scratch arrays of a solve, kept across solves so a cycle allocates nothing.
struct MultigridWorkspace {
  std::vector<double> residual, correction, scratch, direction, operated;
  void resize(std::size_t n, bool krylov) {
    residual.resize(n);
    correction.resize(n);
    scratch.resize(n);
    if (krylov) {
      direction.resize(n);
      operated.resize(n);
    }
  }
};

namespace detail {

// Volume-weighted sum of f(c) over the leaves (a distributed tree: the owned leaves of
// every rank), and the leaves' volume. Compensated partial sums, added exactly: the same
// to the last bit, in practice, however the leaves are split over threads and ranks (the
// residual histories of singular solves on N ranks match one rank's).
template <int D, class F>
std::pair<double, double> leaf_integral(const tree::Tree<D>& t, F&& f) {
  parallel::ExactSum sum, volume;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double vol = std::pow(t.cell_size(l), D);
    const auto [begin, end] = t.owned_range(l);  // the whole level on one rank
#pragma omp parallel if (end - begin > tree::kParallelMin)
    {
      parallel::CompensatedSum s;
      double count = 0.0;
#pragma omp for schedule(static) nowait
      for (tree::Index i = begin; i < end; ++i)
        if (lv.leaf[i] && t.owns(lv.base + i)) {
          s.add(f(lv.base + i));
          count += 1.0;
        }
#pragma omp critical(capsflow_leaf_integral)
      {
        s.add_scaled_to(sum, vol);
        parallel::CompensatedSum{count, 0.0}.add_scaled_to(volume, vol);
      }
    }
  }
  return {t.global_sum(sum), t.global_sum(volume)};
}

template <int D>
double leaf_mean(const tree::Tree<D>& t, std::span<const double> v) {
  const auto [sum, volume] = leaf_integral<D>(t, [&](tree::Index c) { return v[c]; });
  return sum / volume;
}

template <int D>
double leaf_dot(const tree::Tree<D>& t, std::span<const double> x, std::span<const double> y) {
  return leaf_integral<D>(t, [&](tree::Index c) { return x[c] * y[c]; }).first;
}

template <int D>
double leaf_max_abs(const tree::Tree<D>& t, std::span<const double> v) {
  double worst = 0.0;
  const auto leaves = t.owned_leaves();
  const auto n = static_cast<tree::Index>(leaves.size());
#pragma omp parallel for schedule(static) reduction(max : worst) if (n > tree::kParallelMin)
  for (tree::Index i = 0; i < n; ++i) worst = std::max(worst, abs_or_infinity(v[leaves[i]]));
  return t.global_max(worst);
}

// Whether every span has one entry per cell of t (checked builds: fields passed to the
// cycle after an adapt must have been resized with it).
template <int D>
bool spans_cells(const tree::Tree<D>& t, std::initializer_list<std::span<double>> fields) {
  for (const auto& f : fields)
    if (f.size() != static_cast<std::size_t>(t.num_cells())) return false;
  return true;
}

// Whether cell c is pinned (an operator whose lambda pins the cells without fluid: they are
// outside its null space, so the means below leave them out).
template <class Op>
bool pinned(const Op& op, tree::Index c) {
  if constexpr (requires { op.pinned(c); }) return op.pinned(c);
  else return false;
}

// The volume mean of v over the leaves that are not pinned.
template <class Op>
double free_mean(const Op& op, std::span<const double> v) {
  constexpr int D = Op::kDimension;
  const auto [sum, volume] = leaf_integral<D>(op.tree(), [&](tree::Index c) { return pinned(op, c) ? 0.0 : v[c]; });
  if constexpr (requires { op.pinned(tree::Index{}); }) {
    const auto [free_volume, unused] = leaf_integral<D>(op.tree(), [&](tree::Index c) { return pinned(op, c) ? 0.0 : 1.0; });
    (void)unused;
    return free_volume > 0.0 ? sum / free_volume : 0.0;
  } else {
    return sum / volume;
  }
}

// Subtracts the mean of v over the leaves that are not pinned from them: a residual made
// compatible for a singular operator, or a solution with its constant fixed.
template <class Op>
void remove_mean(const Op& op, std::span<double> v) {
  const double mean = free_mean(op, v);
  op.tree().for_each_leaf([&](tree::Index c) {
    if (!pinned(op, c)) v[c] -= mean;
  });
}

}  // namespace detail

// One cycle: da (on the leaves) approximately solves L(da) = res with homogeneous
// boundary conditions. res on the parents must hold the restriction of its leaf values
// when `restricted` (Op::residual leaves it so), else it is restricted here. A non-empty
// `corrected` gets += da on the leaves, each level as soon as its da is final.
template <class Op>
void vcycle(const Op& op, std::span<double> res, std::span<double> da, std::span<double> scratch,
            const MultigridOptions& opt, std::span<double> corrected = {}, bool restricted = false) {
  const auto& t = op.tree();
  CAPSFLOW_ASSERT(detail::spans_cells(t, {res, da, scratch}) && (corrected.empty() || detail::spans_cells(t, {corrected})),
                  "multigrid vcycle: a field does not have the tree's num_cells entries");
  // Distributed: the ghosts' residuals too.
  if (!restricted) t.restrict_and_exchange(res);
  else t.exchange_restricted(res);
  for (int l = 0; l <= t.depth(); ++l) {
    if (l == 0) {
      const auto& lv = t.level(0);
      for (tree::Index c = lv.active_begin(); c < lv.active_end(); ++c) da[c] = 0.0;
    } else {
      t.prolong_level(l, da, tree::Prolongation::linear);
      t.fill_halo(l, da, tree::Prolongation::linear, tree::Tree<Op::kDimension>::HaloCells::face_read, op.injected_halos());
    }
    t.fill_boundary_cells(l, da, op.correction_bc());
    op.relax(l, da, res, l == 0 ? opt.coarsest_sweeps : opt.relax_sweeps, opt, scratch, corrected);
  }
}

namespace detail {
// res = b - L(a) with a's halos synced first; max |res| over this rank's owned leaves (a
// ghost's stencil may reach cells this rank does not have).
template <class Op>
double synced_residual(const Op& op, std::span<double> a, std::span<const double> b, std::span<double> res) {
  // Quadratic halo values keep the leaf operator second order across resolution jumps.
  op.tree().sync_leaf_neighbors(a, op.bc(), tree::Prolongation::quadratic, op.injected_halos());
  return op.residual(a, b, res);
}
}  // namespace detail

// max |b - L(a)| over every rank's leaves, for a first guess to be compared before a solve
// (a's halos synced here); for operators that are not singular.
template <class Op>
double residual_max(const Op& op, std::span<double> a, std::span<const double> b, MultigridWorkspace& ws) {
  CAPSFLOW_ASSERT(!op.singular(), "multigrid residual_max: a singular operator's residual needs its mean removed");
  ws.resize(op.tree().num_cells(), false);
  return op.tree().global_max(detail::synced_residual(op, a, b, ws.residual));
}

template <class Op>
MultigridStats solve(const Op& op, std::span<double> a, std::span<const double> b,
                     MultigridWorkspace& ws, const MultigridOptions& opt) {
  constexpr int D = Op::kDimension;
  const tree::Tree<D>& t = op.tree();
  CAPSFLOW_ASSERT(detail::spans_cells(t, {a}) && b.size() == static_cast<std::size_t>(t.num_cells()),
                  "multigrid solve: the solution or right-hand side does not have the tree's num_cells entries");
  // A non-finite right-hand side is not asserted against: a flow that blows up within a
  // step hands its solves NaN, and the run reports the blow-up after the step. The
  // residual is then infinite (abs_or_infinity), no cycle runs, and the solve reports
  // not converged.
  ws.resize(t.num_cells(), opt.krylov || opt.krylov_on_growth);
  std::span<double> res = ws.residual, da = ws.correction, scratch = ws.scratch;
  const bool singular = op.singular();
  if (!opt.warm_start) t.for_each_leaf([&](tree::Index c) { a[c] = 0.0; });

  // The residual comes restricted, unless the mean is then removed from its leaves.
  const bool restricted = !singular;
  auto compute_residual = [&] {
    const double worst = detail::synced_residual(op, a, b, res);
    if (!singular) return t.global_max(worst);  // distributed: then over all ranks
    detail::remove_mean(op, res);
    return detail::leaf_max_abs<D>(t, res);
  };
  auto fix_mean = [&] {
    if (singular) detail::remove_mean(op, a);
  };

  MultigridStats stats;
  stats.initial_residual = compute_residual();
  stats.residuals.push_back(stats.initial_residual);
  double current = stats.initial_residual;
  // Krylov state: previous direction p, its image q = L0 p, and <p, q>.
  std::span<double> p = ws.direction, q = ws.operated;
  double pq_old = 0.0;
  bool krylov = opt.krylov;
  int krylov_steps = 0;
  // No cycle can repair a non-finite residual: stop at once.
  while (stats.cycles < opt.max_cycles && (stats.cycles < opt.min_cycles || current > opt.tolerance) &&
         std::isfinite(current)) {
    if (!krylov) {
      // a += da; a ghost's a is wrong here (its da was fused in before the exchange) until
      // compute_residual's sync brings the owners' values.
      vcycle(op, res, da, scratch, opt, a, restricted);
    } else {
      // z = B r (a cycle writes res on the parents only: the leaves stay for the step).
      vcycle(op, res, da, scratch, opt, {}, restricted);
      if (singular) detail::remove_mean(op, da);
      // The first direction is z itself: p's old entries are not read (0 times a stale entry
      // is NaN when that entry is not finite: measured on 2 ranks in the checked build, where
      // krylov_on_growth first switched mid-solve).
      if (krylov_steps++ > 0) {
        const double beta = -detail::leaf_dot<D>(t, da, q) / pq_old;
        t.for_each_leaf([&](tree::Index c) { p[c] = da[c] + beta * p[c]; });
      } else {
        t.for_each_leaf([&](tree::Index c) { p[c] = da[c]; });
      }
      t.sync_leaf_neighbors(p, op.correction_bc(), tree::Prolongation::quadratic, op.injected_halos());
      op.apply_leaves(p, q);  // L0 p: p's boundary cells hold homogeneous values
      pq_old = detail::leaf_dot<D>(t, p, q);
      // p = 0: the residual was zero (a cycle forced by min_cycles on a solved system);
      // the step would be 0 / 0.
      if (pq_old == 0.0) break;
      const double step = detail::leaf_dot<D>(t, p, res) / pq_old;
      t.for_each_leaf([&](tree::Index c) { a[c] += step * p[c]; });
    }
    fix_mean();
    const double previous = current;
    current = compute_residual();
    stats.residuals.push_back(current);
    ++stats.cycles;
    if (!krylov && opt.krylov_on_growth && current > previous) krylov = stats.switched_to_krylov = true;
  }
  // a leaves synced as without injected halos (its readers need not weigh them by zero).
  if (const tree::InjectedHalos* injected = op.injected_halos())
    t.refill_injected_halos(a, op.bc(), tree::Prolongation::quadratic, *injected);
  stats.final_residual = current;
  stats.converged = current <= opt.tolerance;
  return stats;
}

}  // namespace capsflow::fluid
