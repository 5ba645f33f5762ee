// multigrid/… benchmarks: Poisson on uniform 64^3 and 128^3 cubes and on the seed channel
// refined around the capsule shell. Reported per V-cycle (residual and halo/boundary filling
// included), in seconds, in ns per leaf and in dense 7-point Jacobi sweeps over as many
// cells as there are leaves (the unknowns; bench/baseline.hpp), plus cycles to reach 1e-3
// from zero and from the previous solution (the warm start of a time step).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "baseline.hpp"
#include "fluid/multigrid/coefficients.hpp"
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

// A Poisson problem on a tree with what a solve needs (Dirichlet walls, the source above).
struct PoissonCase {
  explicit PoissonCase(const tree::Tree<3>& tree)
      : t(tree),
        op(t, fluid::ConstantFaces{1.0}, fluid::ZeroCells{}, tree::BoundaryConditions<3>::all(tree::BcKind::dirichlet)),
        a(t.num_cells(), 0.0),
        b(t.num_cells(), 0.0) {
    for (const auto c : t.leaves()) b[c] = source(t.center(c), t.options());
  }
  static constexpr int kCycles = 6;
  // Six V-cycles from zero (residuals included, as in a solve); returns seconds per cycle.
  double timed_cycles(double* reduction = nullptr) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto s = fluid::solve(op, a, b, ws, {.tolerance = 0.0, .min_cycles = kCycles, .max_cycles = kCycles, .warm_start = false});
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (reduction) *reduction = s.mean_reduction(4);
    return seconds / kCycles;
  }
  const tree::Tree<3>& t;
  fluid::EllipticOperator<3> op;
  std::vector<double> a, b;
  fluid::MultigridWorkspace ws;
};

void run(benchmark::State& state, tree::Tree<3>& t) {
  PoissonCase p(t);
  // Cold: from zero to 1e-3. Warm: the right-hand side changes by 1%, as between steps.
  const auto cold = fluid::solve(p.op, p.a, p.b, p.ws, {.tolerance = 1e-3, .warm_start = false});
  for (const auto c : t.leaves()) p.b[c] *= 1.01;
  const auto warm = fluid::solve(p.op, p.a, p.b, p.ws, {.tolerance = 1e-3});

  double seconds = 0.0;
  double reduction = 0.0;
  std::int64_t n = 0;
  for (auto _ : state) {
    seconds += p.timed_cycles(&reduction);
    ++n;
  }
  const double per_cycle = seconds / double(n);
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

// O(N): the cost per leaf of a V-cycle on 128^3 against 64^3. Timed alternately (one
// solve of each per iteration) so that the machine's drift over a run, which is larger
// than the effect measured, hits both alike; medians over the iterations.
void BM_MultigridUniformScaling(benchmark::State& state) {
  const tree::Tree<3> small = uniform_cube(6), large = uniform_cube(7);
  PoissonCase p_small(small), p_large(large);
  std::vector<double> ns_small, ns_large;
  (void)p_small.timed_cycles();
  (void)p_large.timed_cycles();
  for (auto _ : state) {
    ns_small.push_back(p_small.timed_cycles() / small.num_leaves() * 1e9);
    ns_large.push_back(p_large.timed_cycles() / large.num_leaves() * 1e9);
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double s = median(ns_small), l = median(ns_large);
  state.counters["threads"] = omp_get_max_threads();
  state.counters["ns_per_cell_per_vcycle_64"] = s;
  state.counters["ns_per_cell_per_vcycle_128"] = l;
  state.counters["ratio_128_to_64"] = l / s;  // target <= 1.2
}
BENCHMARK(BM_MultigridUniformScaling)->Name("multigrid/poisson_uniform_scaling")->Unit(benchmark::kMillisecond)->MinTime(5.0);

void BM_MultigridSeedShell(benchmark::State& state) {
  tree::Tree<3> t = seed_shell_tree();
  run(state, t);
}
BENCHMARK(BM_MultigridSeedShell)->Name("multigrid/poisson_seed_shell")->Unit(benchmark::kMillisecond)->MinTime(1.0);

// The viscous solve of an inner fluid (NavierStokes::set_properties) against the constant
// one, on the seed shell tree: a Helmholtz operator rho/dt - div(mu grad) (seed units: mu = 1,
// rho/dt = 1000), six V-cycles from zero, with the face viscosities as a constant
// (ConstantFaces, the lambda = 1 path), as arrays that hold the constant everywhere
// (EmbeddedFaces, every cell of the uniform class: the variable path's own cost) and as the
// harmonic means of a sphere of radius 0.85 five times as viscous (lambda = 5: the cells
// whose faces all hold 1 take the constant stencil, the others read the arrays). Reported:
// ms per cycle of each and their ratios to the constant one, measured in the same run.
void BM_ViscousVariableAgainstConstant(benchmark::State& state) {
  const tree::Tree<3> t = seed_shell_tree();
  const auto bc = tree::BoundaryConditions<3>::all(tree::BcKind::dirichlet);
  const double mu = 1.0, lambda = -1000.0;
  const auto n = static_cast<std::size_t>(t.num_cells());
  std::vector<double> mu_cells(n, mu), inside(n, mu);
  for (const auto c : t.leaves()) {
    const tree::Point<3> x = t.center(c);
    if (std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]) < bench::kSeedRadius) inside[c] = 5.0 * mu;
  }
  std::vector<double> uniform_faces, sphere_faces;
  fluid::face_coefficients<3>(t, mu_cells, fluid::FaceMean::harmonic, uniform_faces);
  fluid::face_coefficients<3>(t, inside, fluid::FaceMean::harmonic, sphere_faces);
  auto uniform_of = [&](const std::vector<double>& faces) {
    std::vector<std::uint8_t> full(n, 0);
    for (std::size_t c = 0; c < n; ++c)
      full[c] = std::all_of(faces.begin() + static_cast<std::ptrdiff_t>(6 * c), faces.begin() + static_cast<std::ptrdiff_t>(6 * c + 6),
                            [mu](double f) { return f == mu; });
    return full;
  };
  const std::vector<std::uint8_t> all_uniform = uniform_of(uniform_faces), sphere_uniform = uniform_of(sphere_faces);
  std::vector<double> a(n, 0.0), b(n, 0.0);
  for (const auto c : t.leaves()) b[c] = source(t.center(c), t.options());
  fluid::MultigridWorkspace ws;
  const MultigridOptions six{.tolerance = 0.0, .min_cycles = 6, .max_cycles = 6, .warm_start = false};
  auto per_cycle = [&](const auto& op) {
    const auto t0 = std::chrono::steady_clock::now();
    (void)fluid::solve(op, a, b, ws, six);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / 6.0;
  };
  const fluid::EllipticOperator<3, fluid::ConstantFaces, fluid::ConstantCells> constant(t, {mu}, {lambda}, bc);
  const fluid::EllipticOperator<3, fluid::EmbeddedFaces<3>, fluid::ConstantCells> arrays(
      t, {.value = mu, .data = uniform_faces.data(), .full = all_uniform.data()}, {lambda}, bc);
  const fluid::EllipticOperator<3, fluid::EmbeddedFaces<3>, fluid::ConstantCells> sphere(
      t, {.value = mu, .data = sphere_faces.data(), .full = sphere_uniform.data()}, {lambda}, bc);
  double c_s = 0.0, a_s = 0.0, s_s = 0.0;
  std::int64_t runs = 0;
  for (auto _ : state) {
    c_s += per_cycle(constant);
    a_s += per_cycle(arrays);
    s_s += per_cycle(sphere);
    ++runs;
  }
  const auto count = static_cast<double>(runs);
  state.counters["leaves"] = t.num_leaves();
  state.counters["uniform_share_sphere"] =
      static_cast<double>(std::count(sphere_uniform.begin(), sphere_uniform.end(), 1)) / static_cast<double>(n);
  state.counters["constant_ms"] = c_s / count * 1e3;
  state.counters["arrays_ms"] = a_s / count * 1e3;
  state.counters["sphere_ms"] = s_s / count * 1e3;
  state.counters["arrays_over_constant"] = a_s / c_s;
  state.counters["sphere_over_constant"] = s_s / c_s;
}
BENCHMARK(BM_ViscousVariableAgainstConstant)->Name("multigrid/viscous_variable_vs_constant")->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace
