#pragma once
// The numbers a convergence study reports, as plain functions of (spacing, error) points.
#include <utility>
#include <vector>

namespace capsflow::app::study {

struct Segment {
  double h_coarse = 0.0, h_fine = 0.0;  // the step or spacing at both ends
  double e_coarse = 0.0, e_fine = 0.0;  // the errors there
  double order = 0.0;                   // log(e_coarse / e_fine) / log(h_coarse / h_fine); NaN if an error is not > 0
};

// The observed order on each segment between neighbouring points (h, error), taken from the
// coarsest (largest h) to the finest, whatever order the points come in.
[[nodiscard]] std::vector<Segment> observed_orders(std::vector<std::pair<double, double>> points);

// The cost (cells, seconds) at which a series of (error, cost) points reaches `error`:
// linear interpolation of log cost against log error between the two points around it; NaN
// outside the series' range of errors or with fewer than two usable points.
[[nodiscard]] double cost_at_error(std::vector<std::pair<double, double>> error_cost, double error);

}  // namespace capsflow::app::study
