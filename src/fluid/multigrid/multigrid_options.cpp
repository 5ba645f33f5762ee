#include "fluid/multigrid/multigrid_options.hpp"

#include <algorithm>
#include <cmath>

namespace capsflow::fluid {

double MultigridStats::mean_reduction(int n) const {
  n = std::min<int>(n, static_cast<int>(residuals.size()) - 1);
  if (n <= 0 || residuals.front() == 0.0) return 0.0;
  return std::pow(residuals[n] / residuals.front(), 1.0 / n);
}

}  // namespace capsflow::fluid
