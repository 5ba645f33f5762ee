// ibm/... benchmarks: spreading and interpolation for the seed's 10 242-node capsule on the
// seed channel tree (seed_channel.hpp: dx = 1/32, refined in the capsule's shell), the face
// force of the spread field, and the membrane refinement tags.
// One iteration:
//   ibm/spread/<kernel>       point forces -> cell force density (assign mode: the three
//                             cell arrays are zeroed over the whole tree, then accumulated)
//   ibm/interpolate/<kernel>  cell velocities -> node velocities
//   ibm/face_force            cell force -> face force (every fine face, then coarse faces)
//   ibm/tags                  MembraneTags::build + one required-level query per leaf
//   ibm/inside                the inside of the membrane at every leaf near it
//                             (ibm::inside_cells on the P2 sphere's 20 480 flat triangles)
// Counters: nodes, nodes_per_s, leaves, threads, sweep_s (one dense 7-point Jacobi sweep over
// as many cells as the tree has leaves, measured in the same run) and sweeps = seconds per
// iteration / sweep_s: the cost in units of one fluid relaxation sweep.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <chrono>
#include <random>
#include <string>

#include "baseline.hpp"
#include "ibm/indicator.hpp"
#include "ibm/interpolate.hpp"
#include "ibm/refinement_tags.hpp"
#include "ibm/spread.hpp"
#include "membrane/mesh.hpp"
#include "seed_channel.hpp"

namespace {

using namespace capsflow;
using Clock = std::chrono::steady_clock;

// The seed tree and the 10 242-node sphere of radius 0.85 inside its refined shell.
struct SeedCapsule {
  tree::Tree<3> t{bench::seed_channel()};
  Eigen::Matrix3Xd x, f;
  ibm::CellVector u;
  SeedCapsule() {
    t.refine_to(bench::seed_shell(0.0));
    x = membrane::make_icosphere({.level = 5, .radius = bench::kSeedRadius}).nodes;
    std::mt19937 gen(1);
    std::uniform_real_distribution<double> r(-1.0, 1.0);
    f.resize(3, x.cols());
    for (Eigen::Index i = 0; i < x.cols(); ++i) f.col(i) = Eigen::Vector3d(r(gen), r(gen), r(gen));
    for (auto& ud : u) {
      ud.resize(static_cast<std::size_t>(t.num_cells()));
      for (auto& v : ud) v = r(gen);
    }
  }
};

const SeedCapsule& seed() {
  static const SeedCapsule s;
  return s;
}

void report(benchmark::State& state, const SeedCapsule& s, double seconds) {
  const double per_iteration = seconds / static_cast<double>(state.iterations());
  const double sweep = bench::dense_jacobi_sweep_seconds(s.t.num_leaves());
  state.counters["nodes"] = static_cast<double>(s.x.cols());
  state.counters["nodes_per_s"] = static_cast<double>(s.x.cols()) / per_iteration;
  state.counters["leaves"] = s.t.num_leaves();
  state.counters["threads"] = omp_get_max_threads();
  state.counters["sweep_s"] = sweep;
  state.counters["sweeps"] = per_iteration / sweep;
}

template <class F>
void timed(benchmark::State& state, F&& body) {
  double seconds = 0.0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    body();
    benchmark::ClobberMemory();
    seconds += std::chrono::duration<double>(Clock::now() - t0).count();
  }
  report(state, seed(), seconds);
}

void spread(benchmark::State& state, ibm::KernelKind kind) {
  const SeedCapsule& s = seed();
  ibm::CellVector out;
  ibm::SpreadWorkspace ws;
  timed(state, [&] { ibm::spread(kind, s.t, s.x, s.f, out, ws); });
}

void interpolate(benchmark::State& state, ibm::KernelKind kind) {
  const SeedCapsule& s = seed();
  Eigen::Matrix3Xd v;
  const std::array<std::span<const double>, 3> u{s.u[0], s.u[1], s.u[2]};
  timed(state, [&] {
    ibm::interpolate(kind, s.t, u, s.x, v);
    benchmark::DoNotOptimize(v.data());
  });
}

void face_force(benchmark::State& state) {
  const SeedCapsule& s = seed();
  ibm::CellVector cells;
  ibm::SpreadWorkspace ws;
  ibm::spread(ibm::KernelKind::cosine, s.t, s.x, s.f, cells, ws);
  fluid::FaceField<3> faces;
  fluid::resize<3>(faces, s.t);
  timed(state, [&] { ibm::cell_to_face_force<3>(s.t, cells, faces); });
}

void tags(benchmark::State& state) {
  const SeedCapsule& s = seed();
  ibm::MembraneTags tags;
  std::vector<int> required(static_cast<std::size_t>(s.t.num_leaves()));
  timed(state, [&] {
    tags.build(s.t.options(), s.t.max_level(), ibm::band_cells(ibm::KernelKind::cosine, ibm::KernelKind::hat, 2), s.x);
    const auto leaves = s.t.leaves();
    for (std::size_t i = 0; i < leaves.size(); ++i) required[i] = tags(s.t.box(leaves[i]));
    benchmark::DoNotOptimize(required.data());
  });
}

void inside(benchmark::State& state) {
  const SeedCapsule& s = seed();
  const membrane::Mesh mesh =
      membrane::make_icosphere({.order = membrane::Order::p2, .level = 5, .radius = bench::kSeedRadius});
  const auto triangles = membrane::flat_triangles(mesh);
  std::size_t cells = 0;
  timed(state, [&] {
    const auto in = ibm::inside_cells(s.t, mesh.nodes, triangles, ibm::KernelKind::cosine, s.t.max_level());
    cells = in.size();
    benchmark::DoNotOptimize(in.data());
  });
  state.counters["inside_cells"] = static_cast<double>(cells);
}

const bool registered = [] {
  for (const ibm::KernelKind k : {ibm::KernelKind::cosine, ibm::KernelKind::hat, ibm::KernelKind::peskin4}) {
    const std::string name(ibm::name_of(k));
    benchmark::RegisterBenchmark(("ibm/spread/" + name).c_str(), spread, k)->UseRealTime()->Unit(benchmark::kMillisecond);
    benchmark::RegisterBenchmark(("ibm/interpolate/" + name).c_str(), interpolate, k)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond);
  }
  benchmark::RegisterBenchmark("ibm/face_force", face_force)->UseRealTime()->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("ibm/tags", tags)->UseRealTime()->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("ibm/inside", inside)->UseRealTime()->Unit(benchmark::kMillisecond);
  return true;
}();

}  // namespace
