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
#include <chrono>
#include <vector>

#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid {

class StepBody {
 public:
  virtual ~StepBody() = default;
  virtual void forces() = 0;
  virtual void spreading() = 0;
  // The flow step threw: what spreading prepared belongs to the step that failed.
  virtual void flow_failed() {}
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

  // Stages 1-5 of one step; the flow step's statistics.
  StepStats run() {
    for (StepBody* b : bodies_) b->forces();
    for (StepBody* b : bodies_) b->spreading();
    const auto start = std::chrono::steady_clock::now();
    StepStats flow;
    try {
      flow = ns_.step();
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
  NavierStokes<D>& ns_;
  std::vector<StepBody*> bodies_;
};

}  // namespace capsflow::fluid
