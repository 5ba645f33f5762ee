#include "fluid/duct_profile.hpp"

#include <bit>
#include <cmath>

namespace capsflow::fluid {

namespace {
constexpr double kPi = 3.14159265358979323846;
}

double duct_velocity(double y, double z, double a, double b) {
  if (std::abs(y) > a || std::abs(z) > b) return 0.0;
  double sum = 0.0;
  // Terms fall as 1/i^3 (and faster away from the walls); 401 terms give ~1e-8 relative.
  for (int i = 1; i <= 801; i += 2) {
    const double k = i * kPi / (2.0 * a);
    // cosh(k z)/cosh(k b) = exp(k(|z|-b)) (1 + exp(-2k|z|)) / (1 + exp(-2kb)): no overflow.
    const double ratio = std::exp(k * (std::abs(z) - b)) * (1.0 + std::exp(-2.0 * k * std::abs(z))) /
                         (1.0 + std::exp(-2.0 * k * b));
    const double sign = ((i - 1) / 2) % 2 ? -1.0 : 1.0;
    sum += sign * (1.0 - ratio) * std::cos(k * y) / (double(i) * i * i);
  }
  return 16.0 * a * a / (kPi * kPi * kPi) * sum;
}

double duct_flow_rate(double a, double b) {
  double sum = 0.0;
  for (int i = 1; i <= 4001; i += 2) sum += std::tanh(i * kPi * b / (2.0 * a)) / std::pow(double(i), 5);
  return 4.0 * b * a * a * a / 3.0 * (1.0 - 192.0 * a / (std::pow(kPi, 5) * b) * sum);
}

std::size_t DuctProfileMemo::PointHash::operator()(const std::pair<double, double>& p) const {
  const std::uint64_t y = std::bit_cast<std::uint64_t>(p.first), z = std::bit_cast<std::uint64_t>(p.second);
  return std::hash<std::uint64_t>{}(y ^ (z * 0x9e3779b97f4a7c15ULL + (y << 6) + (y >> 2)));
}

double DuctProfileMemo::operator()(double y, double z) const {
  const std::pair<double, double> key{y, z};
  {
    const std::lock_guard<std::mutex> lock(memo_->mutex);
    if (const auto it = memo_->values.find(key); it != memo_->values.end()) return it->second;
  }
  const double v = duct_velocity(y, z, a_, b_);  // outside the lock: other threads go on
  const std::lock_guard<std::mutex> lock(memo_->mutex);
  memo_->values.emplace(key, v);
  return v;
}

}  // namespace capsflow::fluid
