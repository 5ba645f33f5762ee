// fluid/… benchmarks: one full time step (advection unless Stokes, implicit viscosity by
// three Helmholtz solves, projection; tolerance 1e-3, warm starts) on uniform 64^3 and
// 128^3 cubes (a lid-driven cube, Re = 1 or 10) and on the seed channel refined around the
// capsule shell, driven by a radial force on the shell (a capsule relaxing). Reported per
// core (cell_steps_per_s = leaves x steps / s / threads) and in dense Jacobi sweeps over as
// many leaves (bench/baseline.hpp).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <vector>
#include <algorithm>

#include "baseline.hpp"
#include "fluid/navier_stokes.hpp"
#include "seed_channel.hpp"

namespace {

using namespace capsflow;

struct Setup {
  tree::Tree<3> tree;
  fluid::FlowOptions<3> options;
  bool shell_force = false;
  double radius = bench::kSeedRadius;
};

Setup lid_cube(int level, bool stokes) {
  tree::Tree<3> t({.roots = {1, 1, 1}, .max_level = level});
  t.refine_to([level](const tree::Box<3>&) { return level; });
  fluid::FlowOptions<3> o{.Re = stokes ? 1.0 : 10.0, .stokes = stokes, .dt = 1e-3};
  o.boundaries[3] = {.kind = fluid::SideKind::moving_wall, .velocity = {1.0, 0.0, 0.0}};
  return {std::move(t), o, false};
}

// The capsule-like load of the seed case in a uniform walled cube [-1, 1]^3.
Setup shell_cube(int level, bool stokes) {
  tree::Tree<3> t({.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .max_level = level});
  t.refine_to([level](const tree::Box<3>&) { return level; });
  fluid::FlowOptions<3> o{.Re = stokes ? 1.0 : 10.0, .stokes = stokes, .dt = 1e-3};
  return {std::move(t), o, true, 0.6};
}

Setup seed_shell(bool stokes) {
  tree::Tree<3> t(bench::seed_channel());
  t.refine_to(bench::seed_shell(0.0));
  fluid::FlowOptions<3> o{.Re = stokes ? 1.0 : 10.0, .stokes = stokes, .dt = 1e-3};
  o.boundaries[1].kind = fluid::SideKind::outflow;  // as the seed: walls elsewhere
  return {std::move(t), o, true};
}

// A capsule-like load: radial force density on the shell, squeezing along x. Evaluated
// once (the tree does not change): in a coupled run the force comes from spreading, timed
// apart, so its evaluation (exp per face, 15% of a step) is not the fluid's cost.
void set_shell_load(fluid::NavierStokes<3>& ns, double radius) {
  auto load = std::make_shared<fluid::FaceField<3>>();
  ns.set_face_force([radius, load](const tree::Tree<3>& t, fluid::FaceField<3>& f) {
    if ((*load)[0].size() != f[0].size()) {
      *load = f;
      fluid::for_each_face<3>(t, [&](int d, tree::Index, tree::Index hi, double h, const tree::Level<3>&) {
        tree::Point<3> x = t.center_at(t.level_of(hi), t.coords(hi));
        x[d] -= 0.5 * h;
        const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        const double band = std::exp(-std::pow((r - radius) / bench::kSeedFine, 2));
        (*load)[d][hi] = d == 0 ? -20.0 * band * x[0] : 10.0 * band * x[d];
      });
      fluid::restrict_faces<3>(t, *load);
    }
    f = *load;
  });
}

void run(benchmark::State& state, Setup s) {
  fluid::NavierStokes<3> ns(s.tree, s.options);
  if (s.shell_force) set_shell_load(ns, s.radius);
  for (int i = 0; i < 3; ++i) (void)ns.step();  // warm starts become representative
  double seconds = 0.0;
  long steps = 0, cycles = 0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto st = ns.step();
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    cycles += st.cycles();
    ++steps;
  }
  const double per_step = seconds / double(steps);
  const double leaves = s.tree.num_leaves();
  const int threads = omp_get_max_threads();
  state.counters["cells"] = leaves;
  state.counters["threads"] = threads;
  state.counters["step_ms"] = per_step * 1e3;
  state.counters["cell_steps_per_s"] = leaves / per_step / threads;
  state.counters["step_sweeps"] = per_step / bench::dense_jacobi_sweep_seconds(static_cast<std::int64_t>(leaves));
  state.counters["mg_cycles_per_step"] = double(cycles) / double(steps);
}

void BM_StokesUniform(benchmark::State& st) { run(st, lid_cube(static_cast<int>(st.range(0)), true)); }
void BM_NavierStokesUniform(benchmark::State& st) { run(st, lid_cube(static_cast<int>(st.range(0)), false)); }
void BM_StokesSeedShell(benchmark::State& st) { run(st, seed_shell(true)); }
void BM_StokesShellCube(benchmark::State& st) { run(st, shell_cube(static_cast<int>(st.range(0)), true)); }
void BM_NavierStokesSeedShell(benchmark::State& st) { run(st, seed_shell(false)); }

// The seed channel's walls as an embedded box (issue "Walls of any shape"), against the
// brick's own: the same shell, the brick grown by a quarter of the half-width below and
// by 1.75 above in y and z (two roots), so that its walls at +-1 are cut cells (on cell faces
// at the levels >= 3 that meet them) and the rest beyond them solid. The two steps alternate,
// so the machine's drift hits both alike; ratio_embedded_to_brick is the cost
// (target <= 1.5).
// With walls_refined, both trees also reach level 5 on the fluid side of the channel's walls,
// as the case does (adapt.wall_level = 5; relaxation_stokes*.toml): then a tenth of the
// embedded tree's cells are cut or solid, and the wall stencils weigh on the step.
void stokes_seed_embedded_walls(benchmark::State& state, bool walls_refined) {
  auto required = [walls_refined](const tree::Box<3>& b) {
    const int shell = bench::seed_shell(0.0)(b);
    if (!walls_refined) return shell;
    const double eps = 1e-9;
    bool inside = true, touches = false;
    for (int d = 1; d < 3; ++d) {
      inside = inside && b.lo[d] >= -1.0 - eps && b.hi[d] <= 1.0 + eps;
      touches = touches || b.lo[d] <= -1.0 + eps || b.hi[d] >= 1.0 - eps;
    }
    return inside && touches ? std::max(shell, 5) : shell;
  };
  Setup brick = seed_shell(true);
  brick.tree.refine_to(required);
  fluid::NavierStokes<3> plain(brick.tree, brick.options);
  set_shell_load(plain, bench::kSeedRadius);
  tree::Tree<3> grown({.roots = {4, 2, 2}, .root_size = 2.0, .origin = {-4, -1.25, -1.25}, .max_level = bench::kSeedMaxLevel});
  grown.refine_to(required);
  fluid::NavierStokes<3> embedded(grown, brick.options);
  embedded.set_solid(geometry::complement(geometry::box({-10.0, -1.0, -1.0}, {10.0, 1.0, 1.0})));
  set_shell_load(embedded, bench::kSeedRadius);
  for (int i = 0; i < 3; ++i) {
    (void)plain.step();
    (void)embedded.step();
  }
  std::vector<double> brick_ms, embedded_ms;
  long cycles_brick = 0, cycles_embedded = 0, projection_embedded = 0;
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    cycles_brick += plain.step().cycles();
    auto t1 = std::chrono::steady_clock::now();
    const fluid::StepStats st = embedded.step();
    auto t2 = std::chrono::steady_clock::now();
    cycles_embedded += st.cycles();
    projection_embedded += st.projection_cycles;
    brick_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    embedded_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  const double steps = static_cast<double>(brick_ms.size());
  state.counters["brick_ms"] = median(brick_ms);
  state.counters["embedded_ms"] = median(embedded_ms);
  state.counters["ratio_embedded_to_brick"] = median(embedded_ms) / median(brick_ms);
  state.counters["brick_leaves"] = static_cast<double>(brick.tree.num_leaves());
  state.counters["embedded_leaves"] = static_cast<double>(grown.num_leaves());
  state.counters["mg_cycles_brick"] = double(cycles_brick) / steps;
  state.counters["mg_cycles_embedded"] = double(cycles_embedded) / steps;
  state.counters["projection_cycles_embedded"] = double(projection_embedded) / steps;
}

void BM_StokesSeedEmbeddedWalls(benchmark::State& state) { stokes_seed_embedded_walls(state, false); }
void BM_StokesSeedEmbeddedWallsRefined(benchmark::State& state) { stokes_seed_embedded_walls(state, true); }

BENCHMARK(BM_StokesUniform)->Name("fluid/stokes_step_uniform")->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_NavierStokesUniform)->Name("fluid/ns_step_uniform")->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_StokesShellCube)->Name("fluid/stokes_step_uniform_capsule_load")->Arg(6)->Arg(7)->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_StokesSeedShell)->Name("fluid/stokes_step_seed_shell")->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_NavierStokesSeedShell)->Name("fluid/ns_step_seed_shell")->Unit(benchmark::kMillisecond)->MinTime(2.0);
BENCHMARK(BM_StokesSeedEmbeddedWalls)->Name("fluid/stokes_step_seed_embedded_walls")->Unit(benchmark::kMillisecond)->MinTime(4.0);
BENCHMARK(BM_StokesSeedEmbeddedWallsRefined)
    ->Name("fluid/stokes_step_seed_embedded_walls_refined")
    ->Unit(benchmark::kMillisecond)
    ->MinTime(4.0);

}  // namespace
