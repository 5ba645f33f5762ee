#pragma once
// The time-order measurement of the coupled step: the seed's relaxing ellipsoid, coarse
// (dx = 1/8, 642 P2 nodes, a uniform grid so that every run sees the same cells), to t_end
// with dt0, dt0/2, dt0/4 and a reference at dt0/16 of the same scheme; N_inf = max over
// nodes of |X - X_ref|.
#include <array>
#include <cmath>
#include <cstdio>

#include "coupling_support.hpp"

namespace capsflow::ibm::test {

struct OrderRun {
  double Re = 1.0;
  bool crank_nicolson = false;
  bool current_force = false;
  bool carry_faces = false;
  NodeScheme scheme = NodeScheme::ab2;
  double t_end = 0.016;
};

inline Eigen::Matrix3Xd final_positions(const OrderRun& o, double dt) {
  const SeedRun r{.max_level = 4, .dt = dt, .Re = o.Re, .mesh_level = 3, .tolerance = 1e-10,
                  .adapt = {.enabled = false}, .kernels = {.spread = KernelKind::cosine, .interpolate = KernelKind::cosine},
                  .crank_nicolson = o.crank_nicolson, .current_force_in_viscous = o.current_force,
                  .carry_faces = o.carry_faces};
  auto s = test::seed_setup(r);
  s.coupling->set_node_scheme(o.scheme);
  const int steps = static_cast<int>(std::lround(o.t_end / dt));
  for (int n = 0; n < steps; ++n) (void)s.step();
  return s.coupling->capsule(0).x;
}

// Errors at dt0, dt0/2, dt0/4 against dt0/16 with the same scheme.
inline std::array<double, 3> errors(const OrderRun& o, double dt0, const char* label) {
  const Eigen::Matrix3Xd ref = final_positions(o, dt0 / 16);
  std::array<double, 3> e{};
  for (int k = 0; k < 3; ++k) e[k] = (final_positions(o, dt0 / (1 << k)) - ref).colwise().norm().maxCoeff();
  std::printf("%s: N_inf %.3e %.3e %.3e, orders %.2f %.2f\n", label, e[0], e[1], e[2], std::log2(e[0] / e[1]),
              std::log2(e[1] / e[2]));
  return e;
}

// The implicit coupling's dt ladder without a reference: `run` at each dt of `dts` (halving)
// to t_end with the node `scheme` and the solve's `tolerance`; the max-norm differences of
// the final nodes between successive dt, printed with their orders under `label`.
// With viscosity_ratio != 1 the capsule holds an inner fluid that much more viscous.
inline std::vector<double> implicit_ladder(test::SeedRun run, NodeScheme scheme, double tolerance,
                                           std::initializer_list<double> dts, double t_end, const char* label,
                                           double viscosity_ratio = 1.0) {
  std::vector<Eigen::Matrix3Xd> x;
  for (const double dt : dts) {
    run.dt = dt;
    auto s = test::seed_setup(run);
    if (viscosity_ratio != 1.0) {
      CapsuleCoupling& cc = *s.coupling;
      cc.set_inner_fluid(0, {.viscosity_ratio = viscosity_ratio});
      const double mu = 1.0 / run.Re;
      s.ns->set_properties([&cc, mu](const tree::Tree<3>&, std::span<double> rho, std::span<double> m) {
        cc.inner_properties(1.0, mu, rho, m);
      });
    }
    s.coupling->set_node_scheme(scheme);
    s.coupling->set_implicit({.enabled = true, .tolerance = tolerance, .max_iterations = 60});
    const int steps = static_cast<int>(std::lround(t_end / dt));
    for (int k = 0; k < steps; ++k) (void)s.step();
    x.push_back(s.coupling->capsule(0).x);
  }
  std::vector<double> d;
  for (std::size_t k = 0; k + 1 < x.size(); ++k) d.push_back((x[k] - x[k + 1]).colwise().norm().maxCoeff());
  std::printf("%s: N_inf between successive dt", label);
  for (const double v : d) std::printf(" %.3e", v);
  std::printf("; orders");
  for (std::size_t k = 0; k + 1 < d.size(); ++k) std::printf(" %.2f", std::log2(d[k] / d[k + 1]));
  std::printf("\n");
  return d;
}

}  // namespace capsflow::ibm::test
