// The adapt stage (when and to which levels: adaptation.hpp).
#include "fluid/adaptation.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "fluid/walls.hpp"

namespace capsflow::fluid {

template <int D>
Adaptation<D>::Adaptation(NavierStokes<D>& ns, AdaptationOptions options) : ns_(ns), options_(options) {
  const int top = ns_.tree().max_level();
  if (options_.interval < 1)
    throw std::invalid_argument(fmt::format("adaptation: interval {} must be >= 1", options_.interval));
  if (options_.max_interval < 0)
    throw std::invalid_argument(
        fmt::format("adaptation: max_interval {} must be >= 0", options_.max_interval));
  if (!(options_.interval_time >= 0.0) || !(options_.max_interval_time >= 0.0))
    throw std::invalid_argument(fmt::format("adaptation: interval_time {} and max_interval_time {} must be >= 0",
                                            options_.interval_time, options_.max_interval_time));
  if (options_.interval_time > 0.0 && (options_.interval != 1 || options_.max_interval != 0))
    throw std::invalid_argument("adaptation: an interval in time replaces the one in steps (interval 1, max_interval 0)");
  if (options_.max_interval_time > 0.0 && options_.interval_time == 0.0)
    throw std::invalid_argument("adaptation: max_interval_time needs interval_time > 0");
  if (options_.max_interval_time > 0.0 && options_.max_interval_time < options_.interval_time)
    throw std::invalid_argument(fmt::format("adaptation: max_interval_time {} must be 0 or >= interval_time {}",
                                            options_.max_interval_time, options_.interval_time));
  if (options_.min_level < 0 || options_.min_level > top)
    throw std::invalid_argument(
        fmt::format("adaptation: min_level {} is outside [0, max_level {}]", options_.min_level, top));
  if (options_.wall_level < 0 || options_.wall_level > top)
    throw std::invalid_argument(
        fmt::format("adaptation: wall_level {} is outside [0, max_level {}]", options_.wall_level, top));
}

template <int D>
bool Adaptation<D>::solid_at_wall_level(const tree::Box<D>& b) const {
  const EmbeddedGeometry<D>* embedded = ns_.embedded();
  if (!embedded) return false;
  // Only a box of the level above the wall level or finer is tested, at the wall level or
  // its own: a coarser one may hold a fluid region narrower than its cells that no lattice
  // of its own would see.
  const int level = static_cast<int>(std::lround(std::log2(ns_.tree().options().root_size / (b.hi[0] - b.lo[0]))));
  if (level < options_.wall_level - 1) return false;
  return embedded->solid_at_level(b, std::max(level, options_.wall_level));
}

template <int D>
int Adaptation<D>::required_level(const tree::Box<D>& b) const {
  int r = bodies_ ? bodies_->required_level(b) : 0;
  if (options_.wall_level > r && touches_wall<D>(ns_.tree().options(), ns_.options().boundaries, ns_.embedded(), b) &&
      !solid_at_wall_level(b))
    r = options_.wall_level;
  return r;
}

template <int D>
tree::AdaptOptions<D> Adaptation<D>::adapt_options(bool coarsen) const {
  return {.min_level = options_.min_level,
          .required_level = [this](const tree::Box<D>& b) { return required_level(b); },
          .allow_coarsening = coarsen};
}

template <int D>
tree::AdaptCounts Adaptation<D>::forced_passes() {
  const tree::AdaptOptions<D> opt = adapt_options(false);
  tree::AdaptCounts total;
  for (int pass = 0; pass < 64; ++pass) {
    // The bodies' region again: on N ranks each pass repartitions, and a rank then owns
    // leaves whose bands it did not hear of before.
    if (pass > 0 && bodies_) bodies_->update_region();
    // An infinite tolerance: only forced refinement (the velocity may be anything).
    const tree::AdaptCounts c = ns_.adapt(1e300, opt);
    total.refined += c.refined;
    total.leaves = c.leaves;
    total.cells = c.cells;
    // Settled when no rank refined (the counts are each rank's own: every rank must agree).
    if (ns_.tree().global_sum(std::int64_t{c.refined}) == 0) return total;
  }
  throw std::runtime_error("adaptation: the forced refinement did not settle in 64 passes");
}

template <int D>
tree::AdaptCounts Adaptation<D>::refine_initial() {
  if (!options_.enabled) {
    const int top = ns_.tree().max_level();
    return ns_.refine_to([top](const tree::Box<D>&) { return top; });  // the walls made again too
  }
  if (bodies_) bodies_->update_region();
  last_ = forced_passes();
  if (bodies_) bodies_->adapted();
  return last_;
}

template <int D>
bool Adaptation<D>::due(std::int64_t step) const {
  if (!options_.enabled) return false;
  if (options_.interval_time > 0.0) {
    const double dt = ns_.last_dt(), t = ns_.time();
    if (!(dt > 0.0)) return false;  // no step yet
    // The number of whole intervals by time t; the slack absorbs the round-off of a time
    // summed step by step (t = 4 x 1e-3 may be 0.00399999...).
    const auto whole = [&](double s) { return std::floor(s / options_.interval_time + 1e-6); };
    if (whole(t) == whole(t - dt)) return false;
    if (!(options_.max_interval_time > options_.interval_time) || !bodies_) return true;
    // The bodies count steps: the wait in steps at this dt.
    const auto steps = [&](double s) { return static_cast<int>(std::max(1.0, std::round(s / dt))); };
    return !bodies_->may_wait(steps(options_.max_interval_time));
  }
  if (step % options_.interval != 0) return false;
  if (options_.max_interval <= options_.interval || !bodies_) return true;
  return !bodies_->may_wait(options_.max_interval);
}

template <int D>
tree::AdaptCounts Adaptation<D>::adapt() {
  const auto t0 = std::chrono::steady_clock::now();
  if (bodies_) bodies_->update_region();
  tree::AdaptCounts counts =
      ns_.adapt(options_.velocity_tolerance, adapt_options(true), options_.velocity_tolerance_relative);
  // One adapt refines a leaf by one level; a body moves less than its region's margin
  // between adaptations, so this rarely does anything, but a stencil must never miss a cell.
  if (bodies_ && !bodies_->stencils_ready()) {
    const tree::AdaptCounts more = forced_passes();
    counts.refined += more.refined;
    counts.leaves = more.leaves;
    counts.cells = more.cells;
  }
  if (bodies_) bodies_->adapted();
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  last_ = counts;
  return counts;
}

template <int D>
bool Adaptation<D>::after_step(std::int64_t step) {
  if (!options_.enabled) return false;
  if (!due(step)) {
    if (!bodies_ || !bodies_->must_adapt()) return false;
    ++forced_;
  }
  (void)adapt();
  ++count_;
  return true;
}

template class Adaptation<2>;
template class Adaptation<3>;

}  // namespace capsflow::fluid
