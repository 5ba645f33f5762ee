// Navier-Stokes past an embedded cylinder: the DFG benchmark 2D-1 of Schaefer & Turek (1996,
// "Benchmark computations of laminar flow around a cylinder", Notes on Numerical Fluid
// Mechanics 52): a channel of height H = 0.41, a cylinder of diameter D = 0.1 centred at
// (0.2, 0.2), the parabolic inflow of mean 0.2 (maximum 0.3), nu = 1e-3: Re = 20, a steady
// flow. Their bounds: drag coefficient C_D = 2 F_x / (rho U^2 D) in [5.57, 5.59], lift C_L in
// [0.0104, 0.0110], recirculation length L_a (behind the cylinder, along y = 0.2) in
// [0.0842, 0.0852]. The channel here is 6 H = 2.46 long (the benchmark's 2.2: the tree's
// roots are squares), the outflow 2.2 diameters further downstream.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

#include "fluid/navier_stokes.hpp"
#include "fluid/wall_force.hpp"
#include "flow_sides.hpp"

namespace capsflow::fluid::testing {


struct Cylinder2D1 {
  double drag = 0.0, lift = 0.0, recirculation = 0.0;
};

// level: the finest level, around the cylinder (h = 0.41 / 2^level); t_end: the steady state.
inline Cylinder2D1 dfg_2d1(int level, double t_end) {
  const double H = 0.41, D = 0.1, U = 0.2, cx = 0.2, cy = 0.2;
  tree::Tree<2> t({.roots = {6, 1}, .root_size = H, .max_level = level});
  t.refine_to([&](const tree::Box<2>& b) {
    const double x = 0.5 * (b.lo[0] + b.hi[0]), y = 0.5 * (b.lo[1] + b.hi[1]), half = 0.5 * (b.hi[0] - b.lo[0]);
    const double r = std::hypot(x - cx, y - cy);
    if (r < 0.5 * D + 3.0 * half + 0.02) return level;
    if (x > 0.05 && x < 0.6 && std::abs(y - cy) < 0.12) return level - 1;
    return level - 2;
  });
  std::array<SideFlow<2>, 4> sides = all<2>(SideKind::wall);
  sides[0] = {.kind = SideKind::inflow, .profile = InflowProfile::parabolic, .mean_velocity = U};
  sides[1] = {.kind = SideKind::outflow};
  FlowOptions<2> o{.Re = 1000.0, .dt = 0.01, .cfl = 0.8, .boundaries = sides};
  NavierStokes<2> ns(t, o);
  ns.set_solid(geometry::sphere({cx, cy, 0.0}, 0.5 * D));
  while (ns.time() < t_end) {
    const StepStats s = ns.step();
    EXPECT_TRUE(s.converged) << "t = " << ns.time();
  }
  Cylinder2D1 r;
  const auto f = wall_force<2>(ns);
  r.drag = 2.0 * f[0] / (U * U * D);
  r.lift = 2.0 * f[1] / (U * U * D);
  // The recirculation: where u_x along y = 0.2 turns positive behind the cylinder.
  std::vector<std::pair<double, double>> line;
  for (const tree::Index c : t.leaves()) {
    const auto x = t.center(c);
    const double h = t.cell_size(t.level_of(c));
    if (std::abs(x[1] - cy) <= 0.5 * h && x[0] > cx + 0.5 * D && ns.embedded()->volume()[static_cast<std::size_t>(c)] > 0.0)
      line.emplace_back(x[0], ns.u(0)[c]);
  }
  std::sort(line.begin(), line.end());
  for (std::size_t k = 0; k + 1 < line.size(); ++k)
    if (line[k].second < 0.0 && line[k + 1].second >= 0.0) {
      const double x0 = line[k].first, x1 = line[k + 1].first, u0 = line[k].second, u1 = line[k + 1].second;
      r.recirculation = x0 - u0 * (x1 - x0) / (u1 - u0) - (cx + 0.5 * D);
      break;
    }
  std::printf("DFG 2D-1, level %d (D/h = %.0f), t = %.2f: C_D %.4f  C_L %.4f  L_a %.4f\n", level,
              D / t.cell_size(level), ns.time(), r.drag, r.lift, r.recirculation);
  return r;
}

}  // namespace capsflow::fluid::testing
