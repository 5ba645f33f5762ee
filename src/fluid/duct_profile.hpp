#pragma once
// Fully developed laminar flow in a rectangular duct |y| <= a, |z| <= b (b >= a), driven
// by -dp/dx = G, viscosity mu (White, Viscous Fluid Flow, eq. 3-48):
//   u(y, z) = (16 a^2 G / (mu pi^3)) sum_{i odd} (-1)^((i-1)/2) [1 - cosh(i pi z / 2a) /
//             cosh(i pi b / 2a)] cos(i pi y / 2a) / i^3
//   Q = (4 b a^3 G / (3 mu)) [1 - (192 a / (pi^5 b)) sum_{i odd} tanh(i pi b / 2a) / i^5]
// Values here are for G / mu = 1; scale by G / mu.
#include <cstdint>
#include <memory>
#include <mutex>
#include <unordered_map>

namespace capsflow::fluid {

double duct_velocity(double y, double z, double a, double b);
double duct_flow_rate(double a, double b);
inline double duct_mean_velocity(double a, double b) { return duct_flow_rate(a, b) / (4.0 * a * b); }

// duct_velocity for one duct, each point's series summed once. An inflow side asks for the
// same face centres at every boundary fill (several per multigrid cycle), and the series costs
// 401 terms of two exponentials and a cosine: without the memo it was half the time of the
// adaptive duct case. Values are duct_velocity's, bit for bit. Copies share the memo; calls
// may come from several threads. The points asked are the face centres of a finite set of
// levels, so the memo stays small (a 128^2 inflow side at every level: ~22 000 entries).
class DuctProfileMemo {
 public:
  DuctProfileMemo(double a, double b) : a_(a), b_(b), memo_(std::make_shared<Memo>()) {}
  double operator()(double y, double z) const;

 private:
  struct PointHash {
    std::size_t operator()(const std::pair<double, double>& p) const;
  };
  struct Memo {
    std::mutex mutex;
    std::unordered_map<std::pair<double, double>, double, PointHash> values;
  };
  double a_, b_;
  std::shared_ptr<Memo> memo_;
};

}  // namespace capsflow::fluid
