#include "app/study/orders.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace capsflow::app::study {

namespace {
bool usable(double v) { return std::isfinite(v) && v > 0.0; }
}  // namespace

std::vector<Segment> observed_orders(std::vector<std::pair<double, double>> points) {
  std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<Segment> out;
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const auto [hc, ec] = points[i];
    const auto [hf, ef] = points[i + 1];
    const double order = usable(ec) && usable(ef) && hc != hf ? std::log(ec / ef) / std::log(hc / hf)
                                                              : std::numeric_limits<double>::quiet_NaN();
    out.push_back({hc, hf, ec, ef, order});
  }
  return out;
}

double cost_at_error(std::vector<std::pair<double, double>> error_cost, double error) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::erase_if(error_cost, [](const auto& p) { return !usable(p.first) || !usable(p.second); });
  if (error_cost.size() < 2 || !usable(error)) return nan;
  std::sort(error_cost.begin(), error_cost.end());
  for (std::size_t i = 0; i + 1 < error_cost.size(); ++i) {
    const auto [e0, c0] = error_cost[i];
    const auto [e1, c1] = error_cost[i + 1];
    if (error < e0 || error > e1) continue;
    if (e0 == e1) return std::min(c0, c1);
    const double s = std::log(error / e0) / std::log(e1 / e0);
    return std::exp(std::log(c0) + s * std::log(c1 / c0));
  }
  return nan;
}

}  // namespace capsflow::app::study
