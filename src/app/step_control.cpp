#include "app/step_control.hpp"

#include <algorithm>
#include <cmath>

namespace capsflow::app {

void StepControl::after_step(double dt, double error, int order) {
  if (!enabled()) return;
  if (error < 0.0) {  // no estimate: the same step again
    next_ = dt;
    return;
  }
  error_ = error;
  const double factor =
      error_ > 0.0 ? std::clamp(0.9 * std::pow(options_.tolerance / error_, 1.0 / order), 0.25, 2.0) : 2.0;
  next_ = dt * factor;
  if (ceiling_ > 0.0) {
    ceiling_ *= kCeilingGrowth;
    next_ = std::min(next_, ceiling_);
  }
  if (options_.dt_max > 0.0) next_ = std::min(next_, options_.dt_max);
}

void StepControl::reject(double dt) {
  next_ = 0.5 * dt;
  ceiling_ = kCeiling * dt;
  if (options_.dt_max > 0.0) next_ = std::min(next_, options_.dt_max);
}

double StepControl::next(double t, double cap) const {
  const double landed = land(t, std::min(next_, cap));
  // land() may lengthen a step by its slack (1e-6 relative) to reach an instant: then
  // landed below the cap by more than that.
  return landed <= cap ? landed : land(t, cap * (1.0 - 1e-5));
}

double StepControl::land(double t, double dt) const {
  if (!enabled() || !(options_.instants > 0.0)) return dt;
  // The next multiple of the interval; the slack absorbs the round-off of a time summed step
  // by step, as the adaptation's own count of intervals does. The steps up to it are equal:
  // cut short, the last one could be a sliver, and the one after it many times longer, which
  // a multistep rule (BDF2) does not survive.
  const double interval = options_.instants;
  const double next = (std::floor(t / interval + 1e-6) + 1.0) * interval;
  const double rest = next - t;
  // Longer than the rest: on to the last multiple the step reaches (a whole number of
  // intervals once the run is on one).
  if (dt > rest * (1.0 + 1e-6)) return rest + std::floor((dt - rest) / interval + 1e-6) * interval;
  return rest / std::max(1.0, std::ceil(rest / dt - 1e-6));
}

}  // namespace capsflow::app
