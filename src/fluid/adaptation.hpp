#pragma once
// The adapt stage of the time step, for every run (with or without capsules): the one place
// that decides when the tree adapts and to which levels.
//
// Levels: Basilisk's adapt_wavelet on the velocity components (refine above the tolerance,
// coarsen below tolerance / 1.5, NavierStokes::adapt), never below min_level, plus forced
// levels: adapt.wall_level on the leaves touching a wall (walls.hpp: the no-slip sides and
// the embedded walls) and whatever the immersed bodies ask for (BodyRefinement: the capsules' membrane bands at the
// max level). After an adaptation the bodies' stencils must exist; if one still misses a
// cell (one adapt refines a leaf by one level only), forced refinement passes follow.
//
// When: before the first step, forced refinement only (the velocity is not yet a guide)
// until nothing changes; then after every step whose number is a multiple of `interval`,
// and after any step that moved the bodies so far that the next one could leave their
// region (BodyRefinement::must_adapt: a fast capsule is followed whatever the interval).
// The step number is the run's, so a restarted run adapts after the same steps as the
// uninterrupted one. With max_interval > interval and bodies, a due adaptation may wait
// while the bodies say they barely moved (BodyRefinement::may_wait), up to max_interval
// steps. Without adaptation the tree is uniform at the max level from the start.
//
// Or in time (interval_time > 0): after every step that crosses a multiple of interval_time,
// waiting up to max_interval_time. A time-step study then adapts at the same instants for
// every dt, so its members differ by their time error alone (with a cadence in steps the
// seed case's dt = 1e-3 and 5e-4 saw different grids, and N_inf fell at order 0.86 where
// it falls at 2.1 with the same instants: docs/numerics.md). It also keeps the cadence of a
// solver-chosen dt physical. The crossing is of the run's time, which a restart restores.
#include <cstdint>

#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {

struct AdaptationOptions {
  bool enabled = true;                       // false: uniform at the tree's max level, never adapted
  int interval = 1;                          // steps between adaptations
  int max_interval = 0;                      // > interval: the bodies may defer an adaptation up to this
  double interval_time = 0.0;                // > 0: time between adaptations (interval must be 1)
  double max_interval_time = 0.0;            // 0 or >= interval_time: max_interval in time
  double velocity_tolerance = 1e-2;          // wavelet tolerance on each velocity component
  double velocity_tolerance_relative = 0.0;  // NavierStokes::velocity_tolerance
  int min_level = 0;
  int wall_level = 0;  // level forced on leaves touching a wall (0: none)
};

// What bodies immersed in the flow add to the adaptation (ibm::CapsuleCoupling: membrane
// bands). Called once per adaptation, and required_level once per leaf.
template <int D>
class BodyRefinement {
 public:
  virtual ~BodyRefinement() = default;
  // Before an adaptation: the forced region from the bodies' current positions.
  virtual void update_region() = 0;
  // The level a leaf with box b must reach for the bodies (0: none).
  virtual int required_level(const tree::Box<D>& b) const = 0;
  // Whether every cell the bodies' stencils need exists.
  virtual bool stencils_ready() const = 0;
  // Whether an adaptation due now may wait (the bodies moved so little since the last one
  // that their region still covers them until max_interval steps after it).
  virtual bool may_wait(int max_interval) const = 0;
  // Whether the bodies moved so far since the last adaptation that the next step could need
  // cells outside their region: an adaptation then happens now, whatever the interval.
  virtual bool must_adapt() const = 0;
  // After an adaptation.
  virtual void adapted() = 0;
};

template <int D>
class Adaptation {
 public:
  // ns (and its tree) must outlive this. Throws std::invalid_argument for bad options.
  Adaptation(NavierStokes<D>& ns, AdaptationOptions options);

  // The bodies' refinement (nullptr: none); it must outlive this.
  void set_bodies(BodyRefinement<D>* bodies) { bodies_ = bodies; }

  // Before the first step: forced refinement until settled (or uniform at the max level
  // when adaptation is off).
  tree::AdaptCounts refine_initial();
  // A level every leaf of refine_initial's tree reaches (min_level, or the max level when
  // adaptation is off): refining uniformly to it first changes nothing of that tree, so a
  // distributed start builds only this much on every rank and refines the rest in parts.
  [[nodiscard]] int coarsest_initial_level() const {
    return options_.enabled ? options_.min_level : ns_.tree().max_level();
  }
  // After step number `step` of the run: adapts if due; returns whether it did.
  bool after_step(std::int64_t step);
  // One adaptation now (wavelets, forced levels, then stencil passes if needed).
  tree::AdaptCounts adapt();

  // The forced level of a leaf box: walls and bodies.
  [[nodiscard]] int required_level(const tree::Box<D>& b) const;
  // Whether the box, refined to the wall level, would hold no fluid (embedded walls): the
  // wall level is not forced there.
  [[nodiscard]] bool solid_at_wall_level(const tree::Box<D>& b) const;
  [[nodiscard]] const AdaptationOptions& options() const { return options_; }
  [[nodiscard]] double seconds() const { return seconds_; }  // wall-clock time spent adapting
  // Adaptations so far, and how many of them the bodies' motion forced before their interval.
  [[nodiscard]] std::int64_t count() const { return count_; }
  [[nodiscard]] std::int64_t forced_by_bodies() const { return forced_; }
  [[nodiscard]] const tree::AdaptCounts& last() const { return last_; }

 private:
  [[nodiscard]] bool due(std::int64_t step) const;
  tree::AdaptCounts forced_passes();  // refinement only, to the forced levels, until settled
  [[nodiscard]] tree::AdaptOptions<D> adapt_options(bool coarsen) const;

  NavierStokes<D>& ns_;
  AdaptationOptions options_;
  BodyRefinement<D>* bodies_ = nullptr;
  double seconds_ = 0.0;
  std::int64_t count_ = 0, forced_ = 0;
  tree::AdaptCounts last_{};
};

extern template class Adaptation<2>;
extern template class Adaptation<3>;

}  // namespace capsflow::fluid
