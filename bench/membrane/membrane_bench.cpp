// Membrane benchmarks: one force evaluation (energy and nodal forces), one tangent stiffness
// (exact and positive) and one evaluation of the shape diagnostics, on the seed ellipsoid, Skalak C = 1, for the seed's 10 242- and
// 40 962-node meshes, P1 and P2. Threads: whatever OpenMP is given (OMP_NUM_THREADS).
// Counters: nodes, nodes_per_s, s_per_eval, threads, baseline_s (one dense 7-point Jacobi
// sweep over the seed's 1 048 576 fluid cells, measured once per benchmark with the same
// thread count) and sweeps = s_per_eval / baseline_s: the cost of a membrane evaluation in
// units of one fluid relaxation sweep.
#include "baseline.hpp"
#include "membrane/diagnostics.hpp"
#include "membrane/forces.hpp"
#include "membrane/mesh.hpp"
#include "membrane/shapes.hpp"

#include <benchmark/benchmark.h>
#include <omp.h>

#include <chrono>
#include <string>

namespace {

using namespace capsflow::membrane;

constexpr std::int64_t seed_fluid_cells = 1048576;

void report(benchmark::State& state, std::int64_t nodes, double seconds) {
  const double per_eval = seconds / static_cast<double>(state.iterations());
  const double baseline = capsflow::bench::dense_jacobi_sweep_seconds(seed_fluid_cells);
  state.counters["nodes"] = static_cast<double>(nodes);
  state.counters["nodes_per_s"] = static_cast<double>(nodes) / per_eval;
  state.counters["s_per_eval"] = per_eval;
  state.counters["threads"] = omp_get_max_threads();
  state.counters["baseline_s"] = baseline;
  state.counters["sweeps"] = per_eval / baseline;
}

void forces(benchmark::State& state, Order order, int level) {
  MembraneModel model(make_icosphere({.order = order, .level = level, .radius = 0.85}),
                            {.kind = LawKind::skalak, .gs = 1.0, .c = 1.0});
  const Eigen::Matrix3Xd x = seed_ellipsoid(model.mesh().nodes, Eigen::Vector3d::Zero());
  Eigen::Matrix3Xd f(3, x.cols());
  double seconds = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(model.compute_forces(x, f));
    benchmark::ClobberMemory();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  report(state, model.mesh().node_count(), seconds);
}

// The tangent stiffness K = d2E/dX2 (assembled into its fixed pattern; the first call, which
// builds the pattern, is outside the timing), exact or its positive variant.
void stiffness_of(benchmark::State& state, Order order, int level, StiffnessPart part) {
  MembraneModel model(make_icosphere({.order = order, .level = level, .radius = 0.85}),
                      {.kind = LawKind::skalak, .gs = 1.0, .c = 1.0});
  const Eigen::Matrix3Xd x = seed_ellipsoid(model.mesh().nodes, Eigen::Vector3d::Zero());
  (void)model.stiffness(x, part);
  double seconds = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(model.stiffness(x, part).valuePtr());
    benchmark::ClobberMemory();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  report(state, model.mesh().node_count(), seconds);
}

void stiffness(benchmark::State& state, Order order, int level) { stiffness_of(state, order, level, StiffnessPart::exact); }
void positive_stiffness(benchmark::State& state, Order order, int level) {
  stiffness_of(state, order, level, StiffnessPart::positive);
}

void diagnostics(benchmark::State& state, Order order, int level) {
  const Mesh mesh = make_icosphere({.order = order, .level = level, .radius = 0.85});
  const Eigen::Matrix3Xd x = seed_ellipsoid(mesh.nodes, Eigen::Vector3d::Zero());
  double seconds = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(shape_diagnostics(mesh, x));
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  report(state, mesh.node_count(), seconds);
}

const bool registered = [] {
  for (const auto& [kind, fn] :
       {std::pair{"forces", &forces}, std::pair{"stiffness", &stiffness}, std::pair{"positive_stiffness", &positive_stiffness},
        std::pair{"diagnostics", &diagnostics}})
    for (const Order order : {Order::p1, Order::p2})
      for (const int level : {5, 6}) {
        const std::string name = std::string("membrane/") + kind + (order == Order::p1 ? "/P1/" : "/P2/") +
                                 std::to_string(icosphere_node_count(level));
        benchmark::RegisterBenchmark(name.c_str(), fn, order, level)->UseRealTime()->Unit(benchmark::kMicrosecond);
      }
  return true;
}();

}  // namespace
