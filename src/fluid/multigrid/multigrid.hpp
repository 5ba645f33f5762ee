#pragma once
// Geometric multigrid on the tree's own levels (Basilisk's multilevel solver, poisson.h):
// one cycle, written once, for any operator with residual() and relax().
//
// A cycle: the residual r = b - L(a) on the leaves is restricted (volume average) to every
// parent; then, from level 0 to the deepest, the correction da of level l starts as the
// prolongation of level l-1's (zero on level 0), its halo is prolonged from the coarse
// leaves and it is smoothed on the active cells of level l against r; finally a += da on
// the leaves. Leaves of every level are corrected on their own level, parents stand for
// the finer cells below them.
//
// For a singular problem (pure Neumann/periodic, no lambda) the residual's volume mean is
// removed at every cycle (compatibility) and the mean of a is fixed to zero.
#include <cmath>
#include <algorithm>
#include <span>
#include <vector>

#include "fluid/multigrid/multigrid_options.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

// Scratch arrays of a solve, kept across solves so a cycle allocates nothing.
struct MultigridWorkspace {
  std::vector<double> residual, correction, scratch;
  void resize(std::size_t n) {
    residual.resize(n);
    correction.resize(n);
    scratch.resize(n);
  }
};

namespace detail {

// Volume-weighted mean of v over the leaves.
template <int D>
double leaf_mean(const tree::Tree<D>& t, std::span<const double> v) {
  double sum = 0.0, volume = 0.0;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double vol = std::pow(t.cell_size(l), D);
    double s = 0.0;
    tree::Index count = 0;
#pragma omp parallel for schedule(static) reduction(+ : s, count) if (lv.n_active > tree::kParallelMin)
    for (tree::Index i = 0; i < lv.n_active; ++i)
      if (lv.leaf[i]) {
        s += v[lv.base + i];
        ++count;
      }
    sum += s * vol;
    volume += count * vol;
  }
  return sum / volume;
}

template <int D>
void add_to_leaves(const tree::Tree<D>& t, std::span<double> a, std::span<const double> da, double shift) {
  t.for_each_leaf([&](tree::Index c) { a[c] += da[c] - shift; });
}

}  // namespace detail

template <class Op>
MultigridStats solve(const Op& op, std::span<double> a, std::span<const double> b,
                     MultigridWorkspace& ws, const MultigridOptions& opt) {
  constexpr int D = Op::kDimension;
  const tree::Tree<D>& t = op.tree();
  ws.resize(t.num_cells());
  std::span<double> res = ws.residual, da = ws.correction, scratch = ws.scratch;
  const bool singular = op.singular();
  if (!opt.warm_start) t.for_each_leaf([&](tree::Index c) { a[c] = 0.0; });

  auto compute_residual = [&] {
    // Quadratic halo values keep the leaf operator second order across resolution jumps.
    t.sync(a, op.bc(), tree::Prolongation::quadratic);
    double worst = op.residual(a, b, res);
    if (singular) {
      const double mean = detail::leaf_mean<D>(t, res);
      worst = 0.0;
      for (const tree::Index c : t.leaves()) {
        res[c] -= mean;
        worst = std::max(worst, std::abs(res[c]));
      }
    }
    return worst;
  };

  MultigridStats stats;
  stats.initial_residual = compute_residual();
  stats.residuals.push_back(stats.initial_residual);
  double current = stats.initial_residual;
  while (stats.cycles < opt.max_cycles && (stats.cycles < opt.min_cycles || current > opt.tolerance)) {
    for (int l = t.depth() - 1; l >= 0; --l) t.restrict_level(l, res);
    for (int l = 0; l <= t.depth(); ++l) {
      if (l == 0) {
        const tree::Level<D>& lv = t.level(0);
        for (tree::Index c = lv.active_begin(); c < lv.active_end(); ++c) da[c] = 0.0;
      } else {
        t.prolong_level(l, da, tree::Prolongation::linear);
        t.fill_halo(l, da, tree::Prolongation::linear);
      }
      t.fill_ghosts(l, da, op.correction_bc());
      op.relax(l, da, res, l == 0 ? opt.coarsest_sweeps : opt.relax_sweeps, opt, scratch);
    }
    const double shift = singular ? detail::leaf_mean<D>(t, a) + detail::leaf_mean<D>(t, da) : 0.0;
    detail::add_to_leaves<D>(t, a, da, shift);
    current = compute_residual();
    stats.residuals.push_back(current);
    ++stats.cycles;
  }
  stats.final_residual = current;
  stats.converged = current <= opt.tolerance;
  return stats;
}

}  // namespace capsflow::fluid
