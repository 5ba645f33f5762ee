#pragma once
// Fully developed laminar flow in a rectangular duct |y| <= a, |z| <= b (b >= a), driven
// by -dp/dx = G, viscosity mu (White, Viscous Fluid Flow, eq. 3-48):
//   u(y, z) = (16 a^2 G / (mu pi^3)) sum_{i odd} (-1)^((i-1)/2) [1 - cosh(i pi z / 2a) /
//             cosh(i pi b / 2a)] cos(i pi y / 2a) / i^3
//   Q = (4 b a^3 G / (3 mu)) [1 - (192 a / (pi^5 b)) sum_{i odd} tanh(i pi b / 2a) / i^5]
// Values here are for G / mu = 1; scale by G / mu.
namespace capsflow::fluid {

double duct_velocity(double y, double z, double a, double b);
double duct_flow_rate(double a, double b);
inline double duct_mean_velocity(double a, double b) { return duct_flow_rate(a, b) / (4.0 * a * b); }

}  // namespace capsflow::fluid
