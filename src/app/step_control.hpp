#pragma once
// The time step chosen by accuracy (issue 30, time.tolerance): the membrane nodes' error per
// unit time, estimated after each step against the trapezoidal rule (ibm::CapsuleCoupling::
// node_error), sets the next step.
//
// Euler moves a node by dt V^(n+1); the trapezoidal rule by dt (V^n + V^(n+1)) / 2. Their
// difference per unit time, e = max |V^(n+1) - V^n| / 2 over the nodes, estimates Euler's
// local error per unit time (error per unit step: the global error then scales with the
// tolerance, first order). BDF2's estimate is its error constant times the trapezoidal
// rule's defect. The next step is dt_next = dt min(2, max(1/4, 0.9 (tol / e)^(1/p))), p the
// step's order (BDF2's variable steps stay zero-stable below a ratio of 1 + sqrt 2), capped
// by time.dt_max. A step is not rejected for its error: a flow step cannot be taken back
// once the adaptation followed it, so an error above the tolerance only shortens the next
// step (the first-order error it adds is of the same order). A step whose implicit solve
// failed is taken again at half the length (reject): nothing had moved yet. Steps land on
// the multiples of adapt.interval_time, so adaptations happen at fixed instants whatever
// the steps, and runs at two tolerances adapt at the same instants (studies stay
// comparable): the steps up to the next multiple are equal, each the longest that divides
// the distance evenly without exceeding the proposal; a proposal longer than the distance
// runs on to the last multiple it reaches.
namespace capsflow::app {

class StepControl {
 public:
  struct Options {
    double tolerance = 0.0;  // 0: off (the step is time.dt, or chosen by cfl)
    double first_dt = 1e-3;  // the first step (time.dt)
    double dt_max = 0.0;     // 0: no cap
    double instants = 0.0;   // adapt.interval_time: steps land on its multiples (0: none)
  };
  explicit StepControl(const Options& o) : options_(o), next_(o.first_dt) {}

  [[nodiscard]] bool enabled() const { return options_.tolerance > 0.0; }
  // The next step at time t, before the run's other caps (the end time, the explicit limit).
  [[nodiscard]] double next(double t) const { return land(t, next_); }
  // The same, at most `cap` and landed below it (a cap that must hold: time.coupling = "auto"
  // keeps its explicit steps, run_case.cpp).
  [[nodiscard]] double next(double t, double cap) const;
  // After a step of dt whose node error per unit time was `error`, by a scheme of `order`
  // (a negative error: no estimate, the first step and after a restart that kept none).
  void after_step(double dt, double error, int order = 1);
  // A step of dt that could not be taken (its implicit solve did not converge): the next
  // try is half as long. The proposals after it stay below kCeiling dt, a ceiling that rises
  // by kCeilingGrowth a step, so that a limit that lasts costs a failed solve now and then,
  // not every other step (measured: the coarse quick relaxation with one product allowed
  // failed 65 of 72 steps without the ceiling).
  void reject(double dt);
  static constexpr double kCeiling = 0.7, kCeilingGrowth = 1.05;
  // The estimate of the last step (0 before any).
  [[nodiscard]] double error() const { return error_; }
  // What a checkpoint keeps, so that a restart takes the steps the uninterrupted run takes.
  [[nodiscard]] double proposal() const { return next_; }
  [[nodiscard]] double ceiling() const { return ceiling_; }
  void restore(double proposal, double ceiling) {
    next_ = proposal;
    ceiling_ = ceiling;
  }

 private:
  [[nodiscard]] double land(double t, double dt) const;

  Options options_;
  double next_;
  double error_ = 0.0;
  double ceiling_ = 0.0;  // after a rejection (0: none)
};

}  // namespace capsflow::app
