#pragma once
// A running sum of doubles that carries its rounding errors (Knuth's TwoSum; the
// accumulated error of n terms is about n 2^-106 of the sum of their magnitudes), handed to
// an exact accumulator at the end with the scale multiplied in exactly (FMA). Partial sums
// of the same terms split differently over threads or ranks then agree to far below the
// last bit of the result: the cheap way to make a reduction rank-independent inside a
// loop over cells, where ExactSum itself (about 3 ns a term) would cost a third of a
// multigrid cycle.
#include <cmath>

#include "parallel/exact_sum.hpp"

namespace capsflow::parallel {

struct CompensatedSum {
  double sum = 0.0, error = 0.0;
  void add(double x) {
    const double t = sum + x;
    const double z = t - sum;
    error += (sum - (t - z)) + (x - z);
    sum = t;
  }
  // exact += scale * (sum + error), the product of the main part exact.
  void add_scaled_to(ExactSum& exact, double scale) const {
    const double p = sum * scale;
    exact.add(p);
    exact.add(std::fma(sum, scale, -p));
    exact.add(error * scale);
  }
};

}  // namespace capsflow::parallel
