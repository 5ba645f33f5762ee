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
  if (options_.dt_max > 0.0) next_ = std::min(next_, options_.dt_max);
}

double StepControl::land(double t, double dt) const {
  if (!enabled() || !(options_.instants > 0.0)) return dt;
  // The last multiple of the interval the step reaches; the slack absorbs the round-off of
  // a time summed step by step, as the adaptation's own count of intervals does.
  const double interval = options_.instants;
  const double reached = std::floor((t + dt) / interval + 1e-6) * interval;
  return reached > t + 1e-6 * interval ? reached - t : dt;
}

}  // namespace capsflow::app
