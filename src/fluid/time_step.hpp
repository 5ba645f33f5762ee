#pragma once
// The stages of one time step, and the bodies that take part in them. A body (the capsules
// now; embedded walls and inner fluids next) does its work at named stages and never calls
// the flow solver itself:
//   1. forces         the body's forces at this step's positions;
//   2. spreading      onto the faces the flow reads in its acceleration stage (a body hands
//                     them over through NavierStokes::set_face_force);
//   3. flow           NavierStokes::step, called here and nowhere else in a coupled run;
//   4. interpolation  the new flow at the body's points;
//   5. motion         the body moves with it;
//   6. adaptation     fluid::Adaptation::after_step, by the run loop once the step is done.
// Each stage runs for every body, in the order the bodies were attached, before the next.
//
// An implicit body (an implicit membrane coupling) needs the flow's answer to forces other
// than the ones it spread: between stages 3 and 4 its correct() may spread again and call
// `rerun`, which takes the step again from the same start (NavierStokes::save_state) with
// whatever force is spread now. The last rerun's flow is the step's.
#include <chrono>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {

// Thrown by a body whose step a shorter one may mend: from correct() (an implicit coupling's
// solve that did not converge in its products, or a step that would leave the membrane
// folded), or from forces() or spreading() (positions predicted from the step's length).
// TimeStep::run puts the flow back at the step's start before passing it on, so the caller
// may take the step again, shorter; nothing has moved yet.
class StepTooLong : public std::runtime_error {
 public:
  // at_positions: the step's positions failed (a fold, a wall), not its solve. A membrane
  // can reach those by itself, which no shorter step mends: the caller stops halving at some
  // length (app/run_case.cpp: the explicit coupling's limit).
  explicit StepTooLong(const std::string& what, bool at_positions = false)
      : std::runtime_error(what), at_positions_(at_positions) {}
  [[nodiscard]] bool at_positions() const { return at_positions_; }

 private:
  bool at_positions_;
};

class StepBody {
 public:
  virtual ~StepBody() = default;
  virtual void forces() = 0;
  virtual void spreading() = 0;
  // The flow step threw: what spreading prepared belongs to the step that failed.
  virtual void flow_failed() {}
  // Whether correct() has work this step (then the flow's start is saved before stage 3).
  [[nodiscard]] virtual bool implicit() const { return false; }
  // Between stages 3 and 4: rerun() restores the start, takes the flow step again with the
  // force spread now and returns its statistics.
  virtual void correct(const std::function<StepStats()>& /*rerun*/) {}
  virtual void interpolation() = 0;
  // flow: the flow step's statistics; flow_seconds: its wall time (a face force the body
  // added during it included).
  virtual void motion(const StepStats& flow, double flow_seconds) = 0;
};

template <int D>
class TimeStep {
 public:
  explicit TimeStep(NavierStokes<D>& ns) : ns_(ns) {}
  void attach(StepBody& body) { bodies_.push_back(&body); }

  // Stages 1-5 of one step; the flow step's statistics (with reruns: the cycles of every
  // flow step taken, converged only if every solve was).
  StepStats run() {
    for (StepBody* b : bodies_) b->forces();
    for (StepBody* b : bodies_) b->spreading();
    const auto start = std::chrono::steady_clock::now();
    StepStats flow;
    try {
      std::optional<typename NavierStokes<D>::State> saved;
      for (StepBody* b : bodies_)
        if (b->implicit() && !saved) saved = ns_.save_state();
      flow = ns_.step();
      if (saved) {
        const auto rerun = [&] {
          ns_.restore_state(*saved);
          const StepStats again = ns_.step();
          add_cycles(flow, again);
          return again;
        };
        try {
          for (StepBody* b : bodies_)
            if (b->implicit()) b->correct(rerun);
        } catch (const StepTooLong&) {
          ns_.restore_state(*saved);
          throw;
        }
      }
    } catch (...) {
      for (StepBody* b : bodies_) b->flow_failed();
      throw;
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    for (StepBody* b : bodies_) b->interpolation();
    for (StepBody* b : bodies_) b->motion(flow, seconds);
    return flow;
  }

 private:
  static void add_cycles(StepStats& total, const StepStats& more) {
    total.projection_cycles += more.projection_cycles;
    total.prediction_cycles += more.prediction_cycles;
    total.viscous_cycles += more.viscous_cycles;
    total.converged = total.converged && more.converged;
    total.unconverged += more.unconverged;
  }

  NavierStokes<D>& ns_;
  std::vector<StepBody*> bodies_;
};

}  // namespace capsflow::fluid
