// multigrid/… benchmarks: Poisson on uniform 64^3 and 128^3 cubes and on the seed channel
// refined around the capsule shell. Reported per V-cycle (residual and halo/ghost filling
// included), in seconds, in ns per leaf and in dense 7-point Jacobi sweeps over as many
// cells as there are leaves (the unknowns; bench/baseline.hpp), plus cycles to reach 1e-3
// from zero and from the previous solution (the warm start of a time step).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <vector>

#include "baseline.hpp"
#include "fluid/multigrid/elliptic_operator.hpp"
#include "fluid/multigrid/multigrid.hpp"
#include "seed_channel.hpp"

namespace {

using namespace capsflow;
using fluid::MultigridOptions;

tree::Tree<3> uniform_cube(int level) {
  tree::Tree<3> t({.roots = {1, 1, 1}, .max_level = level});
  t.refine_to([level](const tree::Box<3>&) { return level; });
  return t;
}

tree::Tree<3> seed_shell_tree() {
  tree::Tree<3> t(bench::seed_channel());
  t.refine_to(bench::seed_shell(0.0));
  return t;
}

// A projection-like right-hand side: O(10), smooth, zero on the walls.
double source(const tree::Point<3>& x, const tree::TreeOptions<3>& o) {
  double v = 30.0;
  for (int d = 0; d < 3; ++d) {
    const double len = o.roots[d] * o.root_size;
    v *= std::sin(M_PI * (x[d] - o.origin[d]) / len);
  }
  return v;
}

void run(benchmark::State& state, tree::Tree<3>& t) {
  const auto bc = tree::BoundaryConditions<3>::all(tree::BcKind::dirichlet);
  fluid::EllipticOperator<3> op(t, fluid::ConstantFaces{1.0}, fluid::ZeroCells{}, bc);
  std::vector<double> a(t.num_cells(), 0.0), b(t.num_cells(), 0.0);
  for (const auto c : t.leaves()) b[c] = source(t.center(c), t.options());
  fluid::MultigridWorkspace ws;
  const MultigridOptions base{.tolerance = 1e-3};

  // Cold: from zero to 1e-3. Warm: the right-hand side changes by 1%, as between steps.
  const auto cold = fluid::solve(op, a, b, ws, {.tolerance = 1e-3, .warm_start = false});
  for (const auto c : t.leaves()) b[c] *= 1.01;
  const auto warm = fluid::solve(op, a, b, ws, base);

  constexpr int kCycles = 6;
  double seconds = 0.0;
  double reduction = 0.0;
  std::int64_t n = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto s = fluid::solve(op, a, b, ws,
                                {.tolerance = 0.0, .min_cycles = kCycles, .max_cycles = kCycles, .warm_start = false});
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    reduction = s.mean_reduction(4);
    ++n;
  }
  const double per_cycle = seconds / double(n) / kCycles;
  const double sweep = bench::dense_jacobi_sweep_seconds(t.num_leaves());  // the unknowns
  state.counters["cells"] = t.num_cells();
  state.counters["leaves"] = t.num_leaves();
  state.counters["threads"] = omp_get_max_threads();
  state.counters["vcycle_ms"] = per_cycle * 1e3;
  state.counters["sweeps_per_vcycle"] = per_cycle / sweep;
  state.counters["ns_per_cell_per_vcycle"] = per_cycle / t.num_leaves() * 1e9;
  state.counters["reduction_per_cycle"] = reduction;
  state.counters["cycles_cold"] = cold.cycles;
  state.counters["cycles_warm"] = warm.cycles;
}

void BM_MultigridUniform(benchmark::State& state) {
  tree::Tree<3> t = uniform_cube(static_cast<int>(state.range(0)));
  run(state, t);
}
BENCHMARK(BM_MultigridUniform)->Name("multigrid/poisson_uniform")->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->MinTime(1.0);

void BM_MultigridSeedShell(benchmark::State& state) {
  tree::Tree<3> t = seed_shell_tree();
  run(state, t);
}
BENCHMARK(BM_MultigridSeedShell)->Name("multigrid/poisson_seed_shell")->Unit(benchmark::kMillisecond)->MinTime(1.0);

}  // namespace
