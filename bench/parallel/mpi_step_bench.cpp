// One flow step on N MPI ranks (run under mpirun; bench/parallel/mpi_scaling.sh runs the
// configurations side by side and prints the ratios). Cases:
//   uniform128   the 3D lid-driven cavity on a uniform 128^3 tree (2.1 M cells)
//   seed_shell   the seed channel refined to dx = 1/32 in the capsule's shell, no capsule
// each as unsteady Stokes ("stokes") or Navier-Stokes ("ns"). Prints one line of
// key=value: seconds per step (the slowest rank, after one warm-up step), values sent per
// step by the busiest rank, the fraction of the step that rank spent waiting on messages,
// the ghost cells per level, the exchanges per step and level (all; of them, one-colour
// ones after a red-black half-sweep, half the cells) and of all levels at once, leaves, and the fraction of the step the exchanges cost when
// timed alone (no imbalance: what overlapping them with interior work could hide at most).
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "../seed_channel.hpp"
#include "fluid/navier_stokes.hpp"
#include "parallel/comm.hpp"
#include "parallel/reduce.hpp"
#include "tree/distributed_forest.hpp"

using namespace capsflow;

namespace {

// The adaptation alone: the shell moves by half a finest cell along x and back, each time
// refined where it now lies and coarsened where it left (forced levels only, every flow
// field carried), as the seed case's membrane band does between steps. Seconds per
// adaptation, the slowest rank's.
int adapt_only(const parallel::Comm& comm, fluid::NavierStokes<3>& ns, const std::string& which, int adaptations) {
  if (which != "seed_shell") {
    if (comm.is_root()) std::fprintf(stderr, "capsflow_mpi_bench: adapt runs on seed_shell only\n");
    return 2;
  }
  const auto adapt_to = [&](double centre_x) {
    tree::AdaptOptions<3> opt{.required_level = bench::seed_shell(centre_x), .allow_coarsening = true};
    return ns.adapt(1e300, opt);
  };
  (void)adapt_to(0.5 * bench::kSeedFine);  // warm-up
  if (comm.distributed()) MPI_Barrier(comm.handle());
  const auto start = std::chrono::steady_clock::now();
  std::int64_t changed = 0;
  for (int a = 0; a < adaptations; ++a) {
    const tree::AdaptCounts c = adapt_to(a % 2 == 0 ? 0.0 : 0.5 * bench::kSeedFine);
    changed += c.refined + c.coarsened;
  }
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / adaptations;
  seconds = parallel::global_max(comm, seconds);
  changed = parallel::global_sum(comm, changed);
  const auto leaves = static_cast<long long>(ns.tree().global_leaves());
  if (comm.is_root())
    std::printf("case=%s physics=adapt ranks=%d threads=%s leaves=%lld s_per_adapt=%.4f changed_per_adapt=%.0f\n",
                which.c_str(), comm.size(), std::getenv("OMP_NUM_THREADS") ? std::getenv("OMP_NUM_THREADS") : "?",
                leaves, seconds, double(changed) / adaptations);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  parallel::MpiSession session(argc, argv);
  const parallel::Comm comm = parallel::Comm::world();
  if (argc < 4) {
    if (comm.is_root()) std::fprintf(stderr, "usage: capsflow_mpi_bench uniform128|seed_shell stokes|ns|adapt STEPS\n");
    return 2;
  }
  const std::string which = argv[1], physics = argv[2];
  const int steps = std::atoi(argv[3]);
  tree::TreeOptions<3> to;
  std::function<int(const tree::Box<3>&)> levels;
  fluid::FlowOptions<3> o{.Re = 10, .stokes = physics == "stokes", .dt = 1e-3};
  if (which == "uniform128") {
    to = {.roots = {1, 1, 1}, .max_level = 7};
    levels = [](const tree::Box<3>&) { return 7; };
    o.boundaries[5] = {.kind = fluid::SideKind::moving_wall, .velocity = {1.0}};
  } else {
    to = bench::seed_channel();
    levels = bench::seed_shell(0.0);
    o.boundaries[0] = {.kind = fluid::SideKind::inflow, .profile = fluid::InflowProfile::square_duct, .mean_velocity = 1.0};
    o.boundaries[1] = {.kind = fluid::SideKind::outflow};
  }
  tree::Tree<3> t(to);
  t.refine_to(levels);
  std::unique_ptr<tree::DistributedForest<3>> forest;
  if (comm.size() > 1) forest = tree::distribute(comm, t);
  fluid::NavierStokes<3> ns(t, o);
  if (physics == "adapt") return adapt_only(comm, ns, which, steps);
  (void)ns.step();
  const double wait0 = forest ? forest->seconds_waiting() : 0.0;
  const double colour0 = forest ? forest->seconds_waiting_colour() : 0.0;
  const double reduce0 = forest ? forest->seconds_reducing() : 0.0;
  const auto reductions0 = forest ? forest->reductions() : 0;
  const auto sent0 = forest ? forest->values_sent() : 0;
  if (comm.distributed()) MPI_Barrier(comm.handle());
  const auto start = std::chrono::steady_clock::now();
  int cycles = 0;
  for (int s = 0; s < steps; ++s) cycles += ns.step().cycles();
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / steps;
  const double waiting = forest ? (forest->seconds_waiting() - wait0) / steps : 0.0;
  const double sent = forest ? double(forest->values_sent() - sent0) / steps : 0.0;
  const double waiting_colour = forest ? (forest->seconds_waiting_colour() - colour0) / steps : 0.0;
  const double reducing = forest ? (forest->seconds_reducing() - reduce0) / steps : 0.0;
  const double reductions = forest ? double(forest->reductions() - reductions0) / steps : 0.0;
  double wait_fraction = waiting / seconds;
  double colour_fraction = waiting_colour / seconds, reduce_fraction = reducing / seconds;
  seconds = parallel::global_max(comm, seconds);
  wait_fraction = parallel::global_max(comm, wait_fraction);
  colour_fraction = parallel::global_max(comm, colour_fraction);
  reduce_fraction = parallel::global_max(comm, reduce_fraction);
  const double busiest = parallel::global_max(comm, sent);
  // Per level (the busiest rank's): ghost cells, neighbour ranks, exchanges per step.
  std::string per_level, messages, exchanges, colour_exchanges, level_imbalance;
  if (forest) {
    const auto traffic = forest->traffic();
    for (std::size_t l = 0; l < traffic.ghosts_per_level.size(); ++l) {
      const char* sep = l ? "/" : "";
      const auto level = static_cast<int>(l);
      const auto [first, last] = level <= t.depth() && level > 0 ? t.owned_groups(level) : std::pair<tree::Index, tree::Index>{0, 0};
      // The busiest rank's owned groups of the level over the mean, in percent: the sweeps
      // of a level end in exchanges, so each level's imbalance is waited for on its own.
      const std::int64_t groups = last - first, most = parallel::global_max(comm, groups);
      const std::int64_t total = parallel::global_sum(comm, groups);
      char percent[32];
      std::snprintf(percent, sizeof percent, "%s%.1f", sep, total > 0 ? 100.0 * double(most) * comm.size() / double(total) : 100.0);
      level_imbalance += percent;
      per_level += sep + std::to_string(parallel::global_max(comm, traffic.ghosts_per_level[l]));
      messages += sep + std::to_string(parallel::global_max(comm, traffic.messages_per_level[l]));
      exchanges += sep + std::to_string(parallel::global_max(comm, traffic.exchanges_per_level[l] +
                                                                          traffic.colour_exchanges_per_level[l]) /
                                        (steps + 1));
      colour_exchanges += sep + std::to_string(parallel::global_max(comm, traffic.colour_exchanges_per_level[l]) / (steps + 1));
    }
  }
  // What the messages alone cost: each level's exchange timed back to back (ranks in step,
  // so no imbalance inside), times its exchanges per step. The most that overlapping the
  // exchanges with interior work could hide; the rest of the waiting is imbalance.
  double exchange_seconds = 0.0, whole_exchanges = 0.0, whole_fields = 0.0;
  if (forest) {
    const auto traffic = forest->traffic();
    std::vector<double> scratch(static_cast<std::size_t>(t.num_cells()), 1.0);
    constexpr int kRepeats = 20;
    for (std::size_t l = 0; l < traffic.exchanges_per_level.size(); ++l) {
      // Whole exchanges, and one-colour ones (after a red-black half-sweep: half the cells).
      for (const bool colour : {false, true}) {
        const auto count = colour ? traffic.colour_exchanges_per_level[l] : traffic.exchanges_per_level[l];
        const double per_step = double(parallel::global_max(comm, count)) / (steps + 1);
        MPI_Barrier(comm.handle());
        const auto begin = std::chrono::steady_clock::now();
        for (int r = 0; r < kRepeats; ++r) {
          if (colour) t.update_ghosts(static_cast<int>(l), scratch, r & 1);
          else t.update_ghosts(static_cast<int>(l), scratch);
        }
        const double each = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count() / kRepeats;
        exchange_seconds += per_step * parallel::global_max(comm, each);
      }
    }
    // Exchanges of every level at once (exchange_all: one message per neighbour rank for
    // all levels and the fields it carries), timed with their mean number of fields.
    const double whole_per_step = double(parallel::global_max(comm, traffic.whole_exchanges)) / (steps + 1);
    if (traffic.whole_exchanges > 0) {
      const auto nf = static_cast<std::size_t>(
          std::max<std::int64_t>(1, (traffic.whole_exchange_fields + traffic.whole_exchanges / 2) / traffic.whole_exchanges));
      std::vector<std::vector<double>> fields(nf, scratch);
      std::vector<std::span<double>> spans(fields.begin(), fields.end());
      MPI_Barrier(comm.handle());
      const auto begin = std::chrono::steady_clock::now();
      for (int r = 0; r < kRepeats; ++r) t.update_ghosts(spans);
      const double each = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count() / kRepeats;
      exchange_seconds += whole_per_step * parallel::global_max(comm, each);
    }
    whole_exchanges = whole_per_step;
    if (traffic.whole_exchanges > 0) whole_fields = double(traffic.whole_exchange_fields) / double(traffic.whole_exchanges);
  }
  const auto leaves = static_cast<long long>(t.global_leaves());  // collective: every rank
  // The local tree's cells (owned, ghosts, placeholders, halos and boundary cells: what each
  // rank's fields hold), the busiest rank's: against one rank's tree, the memory per rank.
  const auto local_cells = static_cast<long long>(parallel::global_max(comm, std::int64_t{t.num_cells()}));
  if (comm.is_root())
    std::printf("case=%s physics=%s ranks=%d threads=%s leaves=%lld local_cells=%lld s_per_step=%.4f cycles_per_step=%.1f "
                "values_sent_per_step=%.0f bytes_per_step=%.0f wait_fraction=%.3f wait_colour_fraction=%.3f "
                "reduce_fraction=%.3f reductions_per_step=%.1f ghosts_per_level=%s "
                "neighbours_per_level=%s exchanges_per_step_per_level=%s colour_exchanges_per_step_per_level=%s "
                "busiest_rank_groups_percent_of_mean_per_level=%s all_level_exchanges_per_step=%.0f all_level_fields_per_exchange=%.1f "
                "exchange_fraction=%.3f\n",
                which.c_str(), physics.c_str(), comm.size(), std::getenv("OMP_NUM_THREADS") ? std::getenv("OMP_NUM_THREADS") : "?",
                leaves, local_cells, seconds, double(cycles) / steps, busiest, 8 * busiest,
                wait_fraction, colour_fraction, reduce_fraction, reductions, per_level.c_str(), messages.c_str(), exchanges.c_str(), colour_exchanges.c_str(),
                level_imbalance.c_str(), whole_exchanges, whole_fields, exchange_seconds / seconds);
  return 0;
}
