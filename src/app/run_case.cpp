// `capsflow run`: parse and check the case, build the tree and the flow solver, then the
// time loop with adaptation, diagnostics, snapshots and checkpoints. Everything that can
// be refused is refused before the output directory is touched.
#include "app/run_case.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "app/capsule_set.hpp"
#include "app/energy_budget.hpp"
#include "app/interrupt.hpp"
#include "app/memory_estimate.hpp"
#include "app/output_dir.hpp"
#include "app/progress.hpp"
#include "app/rank_zero.hpp"
#include "app/step_control.hpp"
#include "fluid/adaptation.hpp"
#include "fluid/embedded_surface.hpp"
#include "fluid/navier_stokes.hpp"
#include "fluid/time_step.hpp"
#include "io/atomic_write.hpp"
#include "io/case_config.hpp"
#include "io/case_solids.hpp"
#include "io/checkpoint.hpp"
#include "io/diagnostics_csv.hpp"
#include "io/pvd_series.hpp"
#include "io/vtu_surface.hpp"
#include "io/vtu_tree.hpp"
#include "parallel/collective_counts.hpp"
#include "parallel/comm.hpp"
#include "parallel/sparse_exchange.hpp"
#include "tree/distributed_forest.hpp"

namespace capsflow::app {

namespace {

namespace fs = std::filesystem;

template <int D>
fluid::FlowOptions<D> flow_options(const io::CaseConfig& c) {
  fluid::FlowOptions<D> o;
  o.Re = c.fluid.Re;
  o.stokes = c.fluid.stokes;
  o.crank_nicolson = c.fluid.crank_nicolson;
  o.carry_faces = c.fluid.carry_faces;
  // The implicit coupling needs the flow's response to this step's force damped by this
  // step's viscous solve: with the force a step late in it (Basilisk's lag) a grid-scale force
  // drives the cells by dt f / rho undamped, far above the response at steps longer than the
  // viscous time of a cell, and the fluid gains more energy than the force gives it.
  o.current_force_in_viscous =
      c.fluid.current_force_in_viscous || c.fluid.carry_faces || c.time.coupling != io::Coupling::explicit_forces;
  // BDF2 nodes need the flow's BDF2 steps with the same weights: with backward Euler's the
  // flow's own error keeps the coupled step first order.
  o.bdf2 = c.time.node_scheme == io::NodeScheme::bdf2;
  o.pressure_iterations = c.fluid.pressure_iterations;
  o.dt = c.time.cfl > 0.0 && c.time.dt_max > 0.0 ? c.time.dt_max : c.time.dt;
  // With capsules and cfl > 0 the solver chooses dt (the time loop caps it by the coupling's
  // stability limit): time.dt does not cap it, only dt_max does.
  if (c.time.cfl > 0.0 && c.time.dt_max == 0.0 && !c.capsules.empty()) o.dt = c.time.t_end;
  if (c.time.tolerance > 0.0) o.dt = c.time.t_end;  // the step control (step_control.hpp) caps each step
  o.cfl = c.time.cfl;
  for (int s = 0; s < 2 * D; ++s) {
    const io::BoundaryConfig& b = c.fluid.boundary[s];
    fluid::SideFlow<D>& f = o.boundaries[s];
    switch (b.type) {
      case io::BoundaryType::wall: f.kind = fluid::SideKind::wall; break;
      case io::BoundaryType::moving_wall: f.kind = fluid::SideKind::moving_wall; break;
      case io::BoundaryType::inflow: f.kind = fluid::SideKind::inflow; break;
      case io::BoundaryType::outflow: f.kind = fluid::SideKind::outflow; break;
      case io::BoundaryType::periodic: f.kind = fluid::SideKind::periodic; break;
    }
    for (int d = 0; d < D; ++d) f.velocity[d] = b.velocity[d];
    f.mean_velocity = b.mean_velocity;
    switch (b.profile) {
      case io::InflowProfile::uniform: f.profile = fluid::InflowProfile::uniform; break;
      case io::InflowProfile::parabolic: f.profile = fluid::InflowProfile::parabolic; break;
      case io::InflowProfile::square_duct: f.profile = fluid::InflowProfile::square_duct; break;
      case io::InflowProfile::pipe: f.profile = fluid::InflowProfile::pipe; break;
    }
    f.pipe_radius = b.radius;
    for (int d = 0; d < D; ++d) f.pipe_centre[d] = b.centre[d];
  }
  o.projection = {.tolerance = c.fluid.multigrid.tolerance, .max_cycles = c.fluid.multigrid.max_cycles};
  o.viscous = o.projection;
  return o;
}

fluid::AdaptationOptions adaptation_options(const io::AdaptConfig& a) {
  return {.enabled = a.enabled, .interval = a.interval, .max_interval = a.max_interval,
          .interval_time = a.interval_time, .max_interval_time = a.max_interval_time,
          .velocity_tolerance = a.velocity_tolerance, .velocity_tolerance_relative = a.velocity_tolerance_relative,
          .min_level = a.min_level, .wall_level = a.wall_level};
}

// A capsule failure ("capsule coupling: step N (t = ...): <what>. Likely cause: ...") without
// its advice, where the run gives its own.
std::string failure_with_place(const std::string& message) {
  return message.substr(0, message.find(". Likely cause:"));
}

// Its own part, <what>, for the line that says the step is taken again (the advice is for a
// run that stops).
std::string failure_without_advice(const std::string& message) {
  std::string what = failure_with_place(message);
  if (const auto colon = what.find("): "); colon != std::string::npos) what.erase(0, colon + 3);
  return what;
}

std::string numbered(const char* stem, long step, const char* ext) {
  return fmt::format("{}_{:06d}.{}", stem, step, ext);
}

template <int D>
class FlowRun {
 public:
  FlowRun(const io::CaseConfig& c, const RunRequest& req, fs::path out)
      : case_(c), request_(req), out_(std::move(out)), comm_(parallel::Comm::world()), tree_(io::tree_options<D>(c)),
        ns_(tree_, flow_options<D>(c)),
        adaptation_(ns_, adaptation_options(c.adapt)), progress_(req.quiet) {
    // The solids first: the initial refinement reaches adapt.wall_level along their walls.
    if (!c.solids.empty()) {
      solid_ = io::make_solid(c, req.case_file.string());
      ns_.set_solid(solid_);
    }
    if constexpr (D == 3)
      if (!c.capsules.empty()) {
        capsules_ = std::make_unique<CapsuleSet>(c, ns_);
        adaptation_.set_bodies(&capsules_->coupling());
        time_step_.attach(capsules_->coupling());
      }
    budget_.emplace(ns_, capsules_ ? &capsules_->coupling() : nullptr);
    check_capsules_clear_of_solids();
  }

  // A capsule must not start touching an embedded wall (within the coupling's contact
  // distance; contact forces are not modelled yet): a bad case, before any work.
  void check_capsules_clear_of_solids() const {
    if (!solid_ || !capsules_) return;
    const ibm::CapsuleCoupling& coupling = capsules_->coupling();
    const double contact = coupling.embedded_wall_contact();
    for (int k = 0; k < coupling.num_capsules(); ++k) {
      const Eigen::Matrix3Xd& x = coupling.capsule(k).x;
      Eigen::Index nearest = 0;
      double distance = std::numeric_limits<double>::infinity();
      for (Eigen::Index n = 0; n < x.cols(); ++n) {
        const double d = solid_->signed_distance(x.col(n));
        if (d < distance) {
          distance = d;
          nearest = n;
        }
      }
      if (!(distance > contact))
        throw io::CaseError(fmt::format(
            "{}: capsule[{}].centre: the membrane starts {:.4g} from an embedded wall (node at ({:.4g}, {:.4g}, {:.4g})), "
            "touching it (within a quarter of the finest cell, {:.4g}; contact is not modelled yet); move it or shrink it",
            request_.case_file.string(), k, distance, x(0, nearest), x(1, nearest), x(2, nearest), contact));
    }
  }

  void run() {
    const auto& c = case_;
    long step = 0;
    if (request_.restart) {
      // The checkpoint must fit this case: its time span and its capsules (node counts
      // as built, P2 meshes included).
      io::CheckpointExpectations expect{.t_end = c.time.t_end, .capsule_nodes = std::vector<std::size_t>{}};
      for (int i = 0; capsules_ && i < capsules_->coupling().num_capsules(); ++i)
        expect.capsule_nodes->push_back(static_cast<std::size_t>(capsules_->coupling().capsule(i).x.cols()));
      // On N ranks each reads its share of the leaves and keeps its part (the faces too).
      io::RestoredState state;
      if (comm_.size() > 1) {
        static const std::vector<std::string> kPerLeaf{"face_velocity"};
        io::DistributedRestart<D> part = io::read_checkpoint_distributed<D>(comm_, *request_.restart, tree_, expect, kPerLeaf);
        forest_ = std::move(part.forest);
        state = std::move(part.state);
        for (io::LeafArray& a : part.leaf_arrays) {
          if (a.per_leaf != 2 * D)
            throw io::CheckpointError(fmt::format("{}: /extras/face_velocity holds {} values per leaf, expected {}",
                                                  request_.restart->string(), a.per_leaf, 2 * D));
          restart_faces_ = std::move(a.values);
        }
      } else {
        state = io::read_checkpoint<D>(*request_.restart, tree_, expect);
      }
      ns_.set_time(state.scalars.time);
      step = static_cast<long>(state.scalars.step);
      if (capsules_) capsules_->restore(state.extras, step);
      budget_->restore(state.extras);
      for (const auto& e : state.extras)
        if (e.name == "step_control_proposal" && (e.values.size() == 1 || e.values.size() == 2))
          control_.restore(e.values[0], e.values.size() == 2 ? e.values[1] : 0.0);  // older: no ceiling
        else if (e.name == "flow_history_dt" && e.values.size() == 1)
          ns_.set_history_dt(e.values[0]);
      // The faces (absent from older checkpoints and ones written before any step); on N
      // ranks restored on each rank's leaves once the tree is distributed, below.
      for (const auto& e : state.extras)
        if (e.name == "face_velocity_current" && e.values.size() == 1) restart_faces_current_ = e.values[0] != 0.0;
      for (const auto& e : state.extras)
        if (e.name == "face_velocity") restart_faces_ = e.values;
      if (comm_.size() == 1 && !restart_faces_.empty()) restore_faces();
    } else {
      if (comm_.size() > 1) {
        distribute_coarse_start();
        // The walls on each rank's part: the refinement's criteria skip the solid's cells.
        if (solid_) ns_.set_solid(solid_);
      }
      if (capsules_) capsules_->distribute();  // each rank keeps its own (N ranks)
      (void)adaptation_.refine_initial();
      budget_->start();
    }
    // A restart on N ranks: each rank holds its part of the forest.
    if (comm_.size() > 1 && request_.restart) {
      weigh_membranes();
      if (capsules_) capsules_->distribute();
      if (!restart_faces_.empty()) restore_faces();
    }
    // The embedded walls on the tree the run starts from (a checkpoint's, a distributed one).
    if (solid_) ns_.set_solid(solid_);
    // Diagnostics and the series are rank 0's.
    std::optional<io::DiagnosticsCsv> diagnostics, capsule_rows;
    std::optional<io::PvdSeries> series;
    on_root(comm_, [&] {
      fs::create_directories(out_);
      io::atomic_write_text(out_ / "case.toml", io::to_toml(c));
      auto columns = io::standard_diagnostics_columns();
      columns.emplace_back("mg_unconverged");  // solves that missed their tolerance since the last row
      for (std::string& name : EnergyBudget<D>::columns()) columns.push_back(std::move(name));
      // A restart into a new folder, or over another run (--force), starts its own diagnostics and series.
      const bool in_place = continues_in_place(out_, request_.restart);
      const auto table = [&](const char* name, std::vector<std::string> header) {
        return in_place && fs::exists(out_ / name) ? io::DiagnosticsCsv::resume(out_ / name, std::move(header), double(step))
                                                   : io::DiagnosticsCsv(out_ / name, std::move(header));
      };
      diagnostics = table("diagnostics.csv", columns);
      if (capsules_) capsule_rows = table("capsules.csv", CapsuleSet::columns());
      series = in_place && fs::exists(out_ / "series.pvd") ? io::PvdSeries::load(out_ / "series.pvd")
                                                            : io::PvdSeries(out_ / "series.pvd");
      if (request_.restart) series->truncate_after(ns_.time());
    });
    if (c.output.vtu) write_wall_surface();
    if (!request_.restart && c.output.vtu) snapshot(series, step);

    const auto start = std::chrono::steady_clock::now();
    const long first_step = step;  // a restart times only its own steps
    const parallel::CollectiveCounts collectives_before = parallel::collective_counts();
    const double t_end = c.time.t_end;
    // cfl > 0 or a tolerance with capsules: dt at most kSafety of the explicit coupling's
    // measured stability limit (the implicit coupling has none).
    const bool explicit_coupling = capsules_ && c.time.coupling == io::Coupling::explicit_forces;
    const bool solver_chooses = c.time.cfl > 0.0 || c.time.tolerance > 0.0;
    const double membrane_cap = explicit_coupling && solver_chooses
                                    ? ibm::CapsuleCoupling::kSafety * capsules_->coupling().stability_limit()
                                    : std::numeric_limits<double>::infinity();
    if (explicit_coupling && !solver_chooses) warn_above_stability_limit(c.time.dt);
    // "auto" with BDF2 and a tolerance: the steps stay explicit (at most its threshold). On the
    // seed case an implicit step cost more per unit time than explicit steps at the threshold
    // at every length the controller chose (5 times at 2-30 times the threshold, as much at
    // 250-500 times) and was less accurate (docs/numerics.md, "The explicit steps of auto").
    const bool auto_bdf2 = capsules_ && c.time.coupling == io::Coupling::automatic &&
                           c.time.node_scheme == io::NodeScheme::bdf2;
    const double auto_cap = auto_bdf2 ? capsules_->coupling().implicit_options().explicit_below
                                      : std::numeric_limits<double>::infinity();
    while (ns_.time() < t_end * (1 - 1e-12)) {
      double cap = std::min(t_end - ns_.time(), membrane_cap);
      if (control_.enabled()) cap = std::min(cap, control_.next(ns_.time(), auto_cap));
      ns_.limit_dt(cap);
      fluid::StepStats st;
      try {
        st = time_step_.run();
      } catch (const fluid::StepTooLong& e) {
        // The step control chose a step too long for the implicit solve, or one whose
        // predicted or final positions fold an element or touch a wall (ibm::CapsuleCoupling::
        // fail): the flow is back at the step's start and nothing has moved, so it is taken
        // again at half the length (a few times; with a fixed dt the run stops, the message
        // naming the keys).
        const double tried = ns_.stable_dt();
        // At or below the explicit coupling's limit a step's length is not what folds an
        // element or reaches a wall there: the membrane itself does (halving again would
        // only creep towards it), so the run stops.
        const bool short_already = e.at_positions() && capsules_ && tried <= capsules_->coupling().stability_limit();
        if (short_already && control_.enabled())
          throw RunFailure(fmt::format(
              "{}. Likely cause: the step was taken again down to dt = {:.3g}, within the explicit coupling's limit "
              "{:.3g}, where its length is not what carries the membrane there: the membrane reaches it by itself "
              "(a wall: contact forces are not modelled yet). Output up to the last snapshot is kept in {}",
              failure_with_place(e.what()), tried, capsules_->coupling().stability_limit(), out_.string()));
        if (!control_.enabled() || rejected_in_a_row_ >= kMostRejections)
          throw RunFailure(fmt::format("{} Output up to the last snapshot is kept in {}", e.what(), out_.string()));
        control_.reject(tried);
        ++rejected_in_a_row_;
        ++rejected_;
        if (!request_.quiet)
          on_root(comm_, [&] {
            std::fprintf(stderr, "step %ld, t = %.6g: dt = %.3g was too long (%s); taken again at %.3g\n", step + 1,
                         ns_.time(), tried, failure_without_advice(e.what()).c_str(), control_.next(ns_.time()));
          });
        continue;
      } catch (const std::runtime_error& e) {
        if (!capsules_) throw;  // a capsule's stage failed: a blow-up of this run
        throw RunFailure(fmt::format("{} Output up to the last snapshot is kept in {}", e.what(), out_.string()));
      }
      ++step;
      rejected_in_a_row_ = 0;
      check_convergence(st, step);
      if (control_.enabled()) {
        const auto e = capsules_->coupling().node_error();
        control_.after_step(st.dt, e.error, e.order);
      }
      const bool last = ns_.time() >= t_end * (1 - 1e-12);
      const bool row = step % c.output.diagnostics_interval == 0 || last;
      budget_->after_step(st.dt, row);  // before the adaptation changes the grid
      if (adaptation_.after_step(step)) budget_->after_adaptation();  // the stage after the flow (and membrane) step
      const double vmax = max_speed();
      if (!std::isfinite(vmax)) {
        const std::string membrane =
            capsules_ ? fmt::format(", and the explicit membrane coupling dt < {:.3g}, measured here",
                                    capsules_->coupling().stability_limit())
                      : std::string();
        throw RunFailure(fmt::format(
            "step {}, t = {:.6g}: the velocity is not finite. Likely cause: dt = {:.3g} above the stability "
            "limit (advection needs dt < h / |u|{}): lower time.dt, or set time.cfl > 0 (e.g. 0.5) to keep dt below "
            "it. Output up to the last snapshot is kept in {}",
            step, ns_.time(), st.dt, membrane, out_.string()));
      }
      if (row) {
        const double nan = std::numeric_limits<double>::quiet_NaN();
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const double leaves = double(tree_.global_leaves()), depth = double(tree_.global_depth());
        std::vector<double> energy, per_capsule;  // per_capsule: every capsule's row, on rank 0
        try {  // the membrane energy at the new positions: an element inverted there is a blow-up
          energy = budget_->row();
          if (capsules_) per_capsule = capsules_->rows(step, ns_.time());
        } catch (const std::runtime_error& e) {
          throw RunFailure(fmt::format("{} Output up to the last snapshot is kept in {}", e.what(), out_.string()));
        }
        const CapsuleDiagnostics m = !per_capsule.empty() ? CapsuleSet::from_row(per_capsule)  // capsule 0
                                                          : CapsuleDiagnostics{nan, nan, nan, nan};
        on_root(comm_, [&] {
          std::vector<double> values{double(step), ns_.time(), st.dt, leaves, depth, m.d12, m.d12_bbox, m.area_rel,
                                     m.volume_rel, vmax, double(st.cycles()), wall, double(unconverged_since_row_)};
          values.insert(values.end(), energy.begin(), energy.end());
          diagnostics->row(values);
          const std::size_t width = CapsuleSet::columns().size();
          for (std::size_t k = 0; k < per_capsule.size(); k += width)
            capsule_rows->row(std::span<const double>(per_capsule).subspan(k, width));
        });
        unconverged_since_row_ = 0;
      }
      if (c.output.vtu && (step % c.output.interval == 0 || last)) snapshot(series, step);
      if (c.output.checkpoint &&
          ((c.output.checkpoint_interval > 0 && step % c.output.checkpoint_interval == 0) || last))
        (void)checkpoint(step, st.dt);
      progress_.update({step, ns_.time(), t_end, st.dt, static_cast<tree::Index>(tree_.global_leaves()),
                        tree_.global_depth(), st.cycles()},
                       last);
      if (signal_on_any_rank() != 0) stop_interrupted(step, st.dt);
    }
    progress_.finish();
    const parallel::CollectiveCounts collectives_after = parallel::collective_counts();
    if (c.output.cells_csv) write_cells_csv();
    if (capsules_) {
      capsules_->write_final(out_);  // collective: rank 0 writes
      const std::int64_t moves = tree_.global_sum(capsules_->coupling().migrations());
      const auto& traffic = capsules_->coupling().traffic();
      const std::int64_t words = tree_.global_max(traffic.words_sent);
      const std::int64_t capsules_seen = tree_.global_max(traffic.most_capsules_received);
      const std::int64_t nodes_seen = tree_.global_max(traffic.most_nodes_received);
      const double n = double(std::max<long>(1, step - first_step));
      if (!request_.quiet && forest_) {
        std::fprintf(stderr,
                     "capsules moved between ranks %lld times; capsule traffic: at most %.0f words sent a step by a "
                     "rank, at most %lld of the %d capsules (%lld nodes) routed to a rank at once\n",
                     static_cast<long long>(moves), double(words) / n, static_cast<long long>(capsules_seen),
                     capsules_->coupling().num_capsules(), static_cast<long long>(nodes_seen));
        // What the weak-scaling model multiplies (every rank makes the same calls).
        std::fprintf(stderr, "collectives per step: %.1f reductions, %.2f all-to-all exchanges, %.2f sparse exchanges\n",
                     double(collectives_after.reductions - collectives_before.reductions) / n,
                     double(collectives_after.all_to_all - collectives_before.all_to_all) / n,
                     double(collectives_after.sparse_exchanges - collectives_before.sparse_exchanges) / n);
      }
      if (!request_.quiet) {  // where the time went, per step
        const auto& s = capsules_->coupling().times();
        std::fprintf(stderr, "time per step: membrane %.2f ms, spreading %.2f ms, fluid %.2f ms, interpolation %.2f ms, adapt %.2f ms "
                     "(%lld adaptations, %lld of them before their interval to follow the membrane)\n",
                     1e3 * s.membrane / n, 1e3 * s.spreading / n, 1e3 * s.fluid / n, 1e3 * s.interpolation / n,
                     1e3 * adaptation_.seconds() / n, static_cast<long long>(adaptation_.count()),
                     static_cast<long long>(adaptation_.forced_by_bodies()));
        const auto& implicit = capsules_->coupling().implicit_stats();
        if (implicit.steps > 0)
          std::fprintf(stderr,
                       "implicit coupling: %lld of %.0f steps implicit, %.2f flow steps each besides its two for the "
                       "solve, at most %d; %ld step(s) taken again shorter\n",
                       static_cast<long long>(implicit.steps), n, double(implicit.products) / double(implicit.steps),
                       implicit.most_products, rejected_);
      }
    }
  }

 private:
  // A multigrid solve that stopped at max_cycles above its tolerance: counted for the
  // diagnostics, warned about once, and a run failure with fluid.multigrid.fail_on_unconverged.
  void check_convergence(const fluid::StepStats& st, long step) {
    if (st.unconverged == 0) return;
    unconverged_since_row_ += st.unconverged;
    const auto& mg = case_.fluid.multigrid;
    const std::string what = fmt::format(
        "step {}, t = {:.6g}: {} multigrid solve(s) stopped at max_cycles = {} above the tolerance {:.3g}", step,
        ns_.time(), st.unconverged, mg.max_cycles, mg.tolerance);
    if (mg.fail_on_unconverged)
      throw RunFailure(fmt::format("{} (fluid.multigrid.fail_on_unconverged = true). Raise fluid.multigrid.max_cycles "
                                   "or the tolerance, or reduce dt. Output up to the last snapshot is kept in {}",
                                   what, out_.string()));
    if (!warned_unconverged_) {  // every rank sees the same solves: rank 0 says it
      progress_.finish();
      on_root(comm_, [&] {
        std::fprintf(stderr, "warning: %s; counted in the diagnostics column mg_unconverged (warned once)\n",
                     what.c_str());
      });
      warned_unconverged_ = true;
    }
  }

  // A fixed dt above the explicit coupling's measured stability limit, named before the
  // first step (a new run or a restart, after --set, once on N ranks). A warning, not a
  // refusal: the limit is the lower envelope of measured ones (docs/numerics.md), and runs
  // above it can be stable (the seed Stokes case runs 10 000 steps at 1.5 times it); a run
  // that does blow up stops with a message naming the same limit.
  void warn_above_stability_limit(double dt) {
    const double limit = capsules_->coupling().stability_limit();
    if (!(dt > limit)) return;
    on_root(comm_, [&] {
      std::fprintf(stderr,
                   "warning: time.dt = %.3g is %.1f times the explicit coupling's stability limit measured for this grid "
                   "and membrane, %.3g (a lower bound: the seed Stokes case runs stably at 1.5 times it); if the "
                   "membrane oscillates or blows up, lower time.dt or set time.cfl > 0 (dt then stays below half of it)\n",
                   dt, dt / limit, limit);
    });
  }

  double max_speed() {
    double worst = 0.0;
    for (const auto c : tree_.owned_leaves()) {
      double s = 0.0;
      for (int d = 0; d < D; ++d) s += ns_.u(d)[c] * ns_.u(d)[c];
      if (std::isnan(s)) {  // std::max would drop it
        worst = s;
        break;
      }
      worst = std::max(worst, s);
    }
    return std::sqrt(tree_.global_max(worst));  // NaN from any rank
  }

  // SIGINT or SIGTERM on any rank (the launcher forwards them, not always to every rank at
  // the same step): all ranks stop after the same step.
  int signal_on_any_rank() const {
    const auto local = static_cast<std::int64_t>(interrupt_signal());
    return static_cast<int>(comm_.size() > 1 ? tree_.global_max(local) : local);
  }

  // Calls write(tree) with the whole forest on rank 0: this tree, or on N ranks the one
  // gathered from every rank's leaves (field ids are the same).
  void with_whole_tree(const std::function<void(const tree::Tree<D>&)>& write) {
    if (!forest_) {
      write(tree_);
      return;
    }
    std::optional<tree::Tree<D>> whole = forest_->gather_on_root(tree_);
    on_root(comm_, [&] { write(*whole); });
  }

  fs::path checkpoint(long step, double dt) {
    const fs::path file = out_ / numbered("checkpoint", step, "h5");
    // The capsules' states from their owners (collective), on rank 0, which writes them.
    std::vector<io::ExtraArray> extras = capsules_ ? capsules_->checkpoint_extras() : std::vector<io::ExtraArray>{};
    for (io::ExtraArray& e : budget_->checkpoint_extras()) extras.push_back(std::move(e));
    if (control_.enabled()) extras.push_back({"step_control_proposal", {2}, {control_.proposal(), control_.ceiling()}});
    if (case_.time.node_scheme == io::NodeScheme::bdf2)
      extras.push_back({"flow_history_dt", {1}, {ns_.history_dt()}});
    // The faces the next step starts from, where it reads them (midpoint nodes, carry_faces):
    // without them a restarted run starts from the face mean of the cell velocity and departs
    // from the uninterrupted one. Each rank's own leaves' rows.
    const bool faces_read = case_.fluid.carry_faces || (capsules_ && case_.time.node_scheme == io::NodeScheme::midpoint);
    std::vector<io::LeafArray> leaf_arrays;
    if (faces_read)
      if (std::vector<double> faces = ns_.leaf_faces(); ns_.face_velocity_current() || ns_.face_velocity_carried()) {
        leaf_arrays.push_back({"face_velocity", 2 * D, std::move(faces)});
        extras.push_back({"face_velocity_current", {1}, {ns_.face_velocity_current() ? 1.0 : 0.0}});
      }
    // Every rank writes its leaves into the one file (parallel HDF5 on N ranks).
    io::write_checkpoint<D>(file, tree_, {ns_.time(), step, dt}, extras, leaf_arrays);
    return file;
  }

  // The checkpoint's faces on this rank's leaves (their rows by (level, key)). Collective on N
  // ranks.
  void restore_faces() {
    try {
      ns_.restore_leaf_faces(restart_faces_, restart_faces_current_);
    } catch (const std::invalid_argument& err) {
      throw io::CheckpointError(fmt::format("{}: {}", request_.restart->string(), err.what()));
    }
    restart_faces_.clear();
  }

  // SIGINT or SIGTERM (interrupt.hpp): the step is complete; keep it in a checkpoint whatever
  // output.checkpoint says, so the run can continue with --restart.
  [[noreturn]] void stop_interrupted(long step, double dt) {
    progress_.finish();
    throw Interrupted(interrupt_signal(), step, ns_.time(), checkpoint(step, dt));
  }

  // walls.vtu: the embedded walls as triangles (fluid/embedded_surface.hpp), for ParaView, on
  // the tree the run starts from; on N ranks gathered on rank 0 (one surface, rank by rank).
  void write_wall_surface() const {
    if constexpr (D == 3) {
      if (!ns_.embedded()) return;
      std::vector<double> triangles = fluid::wall_surface(*ns_.embedded());
      if (forest_) {
        std::vector<std::vector<std::uint64_t>> send(static_cast<std::size_t>(comm_.size()));
        send[0].resize(triangles.size());
        std::memcpy(send[0].data(), triangles.data(), triangles.size() * sizeof(double));
        const auto received = parallel::sparse_exchange(comm_, send);
        triangles.clear();
        for (const auto& part : received) {
          const std::size_t at = triangles.size();
          triangles.resize(at + part.size());
          std::memcpy(triangles.data() + at, part.data(), part.size() * sizeof(double));
        }
      }
      on_root(comm_, [&] {
        std::vector<std::int32_t> elements(triangles.size() / 3);
        for (std::size_t k = 0; k < elements.size(); ++k) elements[k] = static_cast<std::int32_t>(k);
        io::write_surface_vtu(out_ / "walls.vtu", {.positions = triangles, .elements = elements});
      });
    }
  }

  // fluid_NNNNNN.vtu on one rank; on N ranks each rank writes its owned leaves as a piece of
  // fluid_NNNNNN.pvtu (no rank gathers the grid), which rank 0 lists once every piece exists.
  void snapshot(std::optional<io::PvdSeries>& series, long step) {
    std::vector<std::span<const double>> u;
    for (int d = 0; d < D; ++d) u.push_back(tree_.values(ns_.velocity(d)));
    std::vector<io::CellField> fields{{"velocity", u}, {"pressure", {tree_.values(ns_.pressure())}}};
    if (ns_.embedded()) fields.push_back({"fluid_fraction", {ns_.embedded()->volume()}});
    if (ns_.variable_properties()) {  // inner fluids: where the capsules' insides are, and what they make
      ns_.refresh_properties();
      fields.push_back({"viscosity", {tree_.values(ns_.viscosity_field())}});
      fields.push_back({"density", {ns_.density()}});
      if constexpr (D == 3)
        if (capsules_) fields.push_back({"inside", {capsules_->coupling().inside()}});
    }
    const std::string file = numbered("fluid", step, forest_ ? "pvtu" : "vtu");
    if (forest_) {
      io::write_tree_pvtu_piece<D>(out_ / file, tree_, fields, comm_.rank(), comm_.size());
      (void)tree_.global_max(std::int64_t{0});  // every piece written before the series lists it
    } else {
      io::write_tree_vtu<D>(out_ / file, tree_, fields);
    }
    on_root(comm_, [&] { series->add(ns_.time(), file); });  // relative to series.pvd, next to it
    if (capsules_) capsules_->snapshot(out_, step, ns_.time(), comm_.is_root() ? &*series : nullptr);
  }

  void write_cells_csv() {
    with_whole_tree([&](const tree::Tree<D>& t) {
      std::string text = D == 2 ? "x,y,level,u.x,u.y,p\n" : "x,y,z,level,u.x,u.y,u.z,p\n";
      for (const auto c : t.leaves()) {
        const auto x = t.center(c);
        for (int d = 0; d < D; ++d) text += fmt::format("{},", x[d]);
        text += fmt::format("{},", t.level_of(c));
        for (int d = 0; d < D; ++d) text += fmt::format("{},", t.values(ns_.velocity(d))[c]);
        text += fmt::format("{}\n", t.values(ns_.pressure())[c]);
      }
      io::atomic_write_text(out_ / "cells_final.csv", text);
    });
  }

  const io::CaseConfig& case_;
  const RunRequest& request_;
  fs::path out_;
  parallel::Comm comm_;
  tree::Tree<D> tree_;
  std::unique_ptr<tree::DistributedForest<D>> forest_;  // N ranks: this rank's part of tree_

  // N ranks, a new run: every rank builds the same coarse forest, uniform to the level every
  // initial leaf reaches anyway (or shallower, once it has kStartLeavesPerRank leaves per
  // rank), and keeps its part; the initial refinement then runs on the distributed tree,
  // each rank refining its own leaves. No rank ever holds the whole initial forest (at 10^8
  // cells it would not fit one node), and the forest is the one a single rank builds:
  // refinement to forced levels does not depend on the order it is done in.
  static constexpr std::int64_t kStartLeavesPerRank = 64;
  void distribute_coarse_start() {
    std::int64_t leaves = 1;
    for (int d = 0; d < D; ++d) leaves *= tree_.options().roots[d];
    int level = 0;
    while (level < adaptation_.coarsest_initial_level() && leaves < kStartLeavesPerRank * comm_.size()) {
      leaves <<= D;
      ++level;
    }
    (void)tree_.refine_to([level](const tree::Box<D>&) { return level; });
    forest_ = tree::distribute(comm_, tree_);
    weigh_membranes();
  }
  // N ranks with capsules: a leaf in a membrane's band weighs adapt.membrane_weight in every
  // later partition (its spreading and interpolation).
  void weigh_membranes() {
    if constexpr (D == 3)
      if (capsules_ && forest_) {
        const std::int64_t weight = case_.adapt.membrane_weight;
        forest_->set_leaf_weight([this, weight](int level, tree::Key key) {
          return capsules_->coupling().leaf_weight(level, key, weight);
        });
      }
  }
  geometry::SolidPtr solid_;  // the [[solid]] tables, or null
  fluid::NavierStokes<D> ns_;
  fluid::Adaptation<D> adaptation_;  // the adapt stage of every step
  fluid::TimeStep<D> time_step_{ns_};  // stages 1-5; the bodies (capsules) attach to it
  StepControl control_{{.tolerance = case_.time.tolerance,
                        .first_dt = case_.time.dt,
                        .dt_max = case_.time.dt_max,
                        .instants = case_.adapt.enabled ? case_.adapt.interval_time : 0.0}};
  std::unique_ptr<CapsuleSet> capsules_;  // 3D cases with [[capsule]] tables
  std::optional<EnergyBudget<D>> budget_;  // the energy columns of diagnostics.csv
  ProgressLine progress_;
  long unconverged_since_row_ = 0;  // the next diagnostics row's mg_unconverged
  // Steps the implicit solve could not take and the step control took again shorter: in a
  // row (at most kMostRejections, a step 1/64 of the proposal) and in the run.
  static constexpr int kMostRejections = 6;
  int rejected_in_a_row_ = 0;
  long rejected_ = 0;
  // A restart's projected faces, this rank's leaves' rows, until restored (after distribution).
  std::vector<double> restart_faces_;
  bool restart_faces_current_ = true;
  bool warned_unconverged_ = false;
};

}  // namespace

void run_case(const RunRequest& req) {
  io::CaseConfig c = io::parse_case(req.case_file, req.overrides);
  if (req.adapt) c.adapt.enabled = *req.adapt;
  const fs::path out = req.out ? *req.out : (c.output.directory.empty() ? fs::path("out") / c.name : fs::path(c.output.directory));
  if (req.restart && !fs::exists(*req.restart))
    throw io::CheckpointError(fmt::format("{}: no such checkpoint file", req.restart->string()));
  if (req.restart && fs::is_directory(*req.restart))
    throw io::CheckpointError(fmt::format("{}: is a directory, not a checkpoint file", req.restart->string()));
  const parallel::Comm comm = parallel::Comm::world();
  check_memory(c, req.max_memory, req.case_file.string(), comm);
  // The cell-centred coupling is kept for comparison, on one rank.
  for (std::size_t k = 0; k < c.capsules.size(); ++k)
    if (comm.size() > 1 && !c.capsules[k].staggered)
      throw io::CaseError(fmt::format("{}: capsule[{}].staggered = false on {} MPI ranks: the cell-centred coupling runs on "
                                      "one rank only (run without mpirun, or with the default staggered coupling)",
                                      req.case_file.string(), k, comm.size()));
  // Embedded walls with carried faces are refused rather than run as if the solids were not
  // there (docs/walls.md).
  if (!c.solids.empty() && c.fluid.carry_faces)
    throw io::CaseError(fmt::format("{}: solid[0]: embedded walls with fluid.carry_faces = true are not implemented yet "
                                    "(docs/walls.md)",
                                    req.case_file.string()));
  bool created = false;
  on_root(comm, [&] { created = prepare_output_dir(out, req.force, req.restart); });
  install_interrupt_handlers();
  // Construction validates the flow options and boundary sides (std::invalid_argument); the
  // checkpoint is read (io::CheckpointError) before anything is written.
  try {
    if (c.dimension == 2) {
      FlowRun<2> run(c, req, out);
      run.run();
    } else {
      FlowRun<3> run(c, req, out);
      run.run();
    }
  } catch (const io::CheckpointError&) {
    remove_if_created_and_empty(out, created);
    throw;
  } catch (const io::CaseError&) {  // a case that only the built run can check (capsules near solids)
    remove_if_created_and_empty(out, created);
    throw;
  } catch (const std::invalid_argument&) {
    remove_if_created_and_empty(out, created);
    throw;
  }
}

}  // namespace capsflow::app
