// tree/… benchmarks on the seed channel refined around the capsule shell (seed_channel.hpp).
// Every time is also reported in dense 7-point Jacobi sweeps over as many cells
// (bench/baseline.hpp), measured in the same run with the same threads.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "baseline.hpp"
#include "seed_channel.hpp"
#include "tree/tree.hpp"

namespace {

using namespace capsflow::tree;

using capsflow::bench::seed_channel;
constexpr int kMaxLevel = capsflow::bench::kSeedMaxLevel;
constexpr double kFine = capsflow::bench::kSeedFine;
auto shell(double centre_x) { return capsflow::bench::seed_shell(centre_x); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void report(benchmark::State& state, const Tree<3>& t, const char* name, double seconds_per_op) {
  const double sweep = capsflow::bench::dense_jacobi_sweep_seconds(t.num_cells());
  state.counters["leaves"] = t.num_leaves();
  state.counters["cells"] = t.num_cells();
  state.counters["bytes_per_leaf"] = double(t.topology_bytes()) / t.num_leaves();
  state.counters["threads"] = omp_get_max_threads();
  state.counters["sweep_ms"] = sweep * 1e3;
  state.counters["op_ms"] = seconds_per_op * 1e3;
  state.counters[name] = seconds_per_op / sweep;
}

// From the roots to the balanced shell, neighbour tables included.
void BM_TreeBuildShell(benchmark::State& state) {
  double total = 0.0;
  std::int64_t n = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    Tree<3> t(seed_channel());
    t.refine_to(shell(0.0));
    total += seconds_since(t0);
    ++n;
    benchmark::DoNotOptimize(t.num_cells());
  }
  Tree<3> t(seed_channel());
  t.refine_to(shell(0.0));
  report(state, t, "build_sweeps", total / double(n));
}
BENCHMARK(BM_TreeBuildShell)->Name("tree/build_shell")->Unit(benchmark::kMillisecond)->MinTime(1.0);

// Flags that move the shell to `centre_x` (refine where required, coarsen elsewhere).
void shell_flags(const Tree<3>& t, double centre_x, std::vector<std::int8_t>& flags) {
  flags.assign(t.num_cells(), 0);
  const auto required = shell(centre_x);
  t.for_each_leaf([&](Index c) {
    const int l = t.level_of(c), r = required(t.box(c));
    flags[c] = r > l ? 1 : (r < l ? -1 : 0);
  });
}

// The small change of every time step: the shell moves by one finest cell, then back.
// Timed: balance, the new topology (all neighbour tables) and nothing else.
void BM_TreeRebuildShellMoved(benchmark::State& state) {
  Tree<3> t(seed_channel());
  t.refine_to(shell(0.0));
  std::vector<std::int8_t> flags;
  int side = 1;
  for (int warm = 0; warm < 4; ++warm, side = -side) {  // reach the alternating steady state
    shell_flags(t, 0.5 * (1 + side) * kFine, flags);
    (void)t.apply_flags(flags);
  }
  double total = 0.0;
  std::int64_t n = 0, changed = 0;
  for (auto _ : state) {
    state.PauseTiming();
    shell_flags(t, 0.5 * (1 + side) * kFine, flags);
    side = -side;
    state.ResumeTiming();
    const auto t0 = std::chrono::steady_clock::now();
    const AdaptCounts c = t.apply_flags(flags);
    total += seconds_since(t0);
    ++n;
    changed += c.refined + c.coarsened;
  }
  report(state, t, "rebuild_sweeps", total / double(n));
  state.counters["cells_changed"] = double(changed) / double(n);
}
BENCHMARK(BM_TreeRebuildShellMoved)->Name("tree/rebuild_shell_moved")->Unit(benchmark::kMillisecond)->MinTime(1.0);

// One full adapt step as a flow solver calls it: three velocity components carried, their
// wavelet estimated, forced refinement around the moving shell, balance, rebuild, transfer.
void BM_TreeAdaptShell(benchmark::State& state) {
  Tree<3> t(seed_channel());
  t.refine_to(shell(0.0));
  FieldId u[3];
  const char* names[3] = {"u", "v", "w"};
  for (int d = 0; d < 3; ++d) u[d] = t.add_field({.name = names[d]});
  auto set_flow = [&] {  // a smooth swirl around the capsule, decaying away from it
    for (const Index c : t.leaves()) {
      const Point<3> x = t.center(c);
      const double g = std::exp(-(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]));
      t.values(u[0])[c] = -x[1] * g;
      t.values(u[1])[c] = x[0] * g;
      t.values(u[2])[c] = 0.1 * g;
    }
  };
  set_flow();
  AdaptOptions<3> opt{.criteria = {{u[0], 1e-2}, {u[1], 1e-2}, {u[2], 1e-2}}, .max_level = kMaxLevel};
  int side = 1;
  for (int warm = 0; warm < 4; ++warm, side = -side) {
    opt.required_level = shell(0.5 * (1 + side) * kFine);
    (void)t.adapt(opt);
  }
  double total = 0.0;
  std::int64_t n = 0;
  for (auto _ : state) {
    opt.required_level = shell(0.5 * (1 + side) * kFine);
    side = -side;
    const auto t0 = std::chrono::steady_clock::now();
    (void)t.adapt(opt);
    total += seconds_since(t0);
    ++n;
  }
  report(state, t, "adapt_sweeps", total / double(n));
}
BENCHMARK(BM_TreeAdaptShell)->Name("tree/adapt_shell")->Unit(benchmark::kMillisecond)->MinTime(1.0);

}  // namespace
