#pragma once
// The 2D lid-driven cavity (unit square, lid u = 1 at y = 1) run to a steady state, and its
// centreline profiles sampled for comparison with Ghia, Ghia & Shin (1982).
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "fluid/navier_stokes.hpp"

namespace capsflow::fluid::testing {

struct GhiaPoint {
  double coord, value;
};

// Reads ghia_re*_{u,v}.csv (grid_index, exact coordinate, Ghia's coordinate, value).
inline std::vector<GhiaPoint> read_ghia(const std::string& file) {
  std::ifstream in(std::string(CAPSFLOW_REFERENCE_DIR) + "/" + file);
  std::vector<GhiaPoint> out;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 'g') continue;
    std::stringstream ss(line);
    std::string field;
    std::vector<double> v;
    while (std::getline(ss, field, ',')) v.push_back(std::stod(field));
    out.push_back({v[1], v[3]});
  }
  return out;
}

// Bilinear interpolation of a synced cell field at x from the leaf containing x and its
// same-level neighbours.
inline double sample(const tree::Tree<2>& t, std::span<const double> v, const tree::Point<2>& x) {
  const Index c = t.locate(x);
  const int l = t.level_of(c);
  const double h = t.cell_size(l);
  const tree::Point<2> xc = t.center(c);
  const double sx = (x[0] - xc[0]) / h, sy = (x[1] - xc[1]) / h;
  const int ox = sx >= 0 ? 1 : -1, oy = sy >= 0 ? 1 : -1;
  const double wx = std::abs(sx), wy = std::abs(sy);
  const auto& lv = t.level(l);
  const Index nx = lv.neighbor(c, tree::slot_of<2>({ox, 0})), ny = lv.neighbor(c, tree::slot_of<2>({0, oy}));
  const Index nxy = lv.neighbor(c, tree::slot_of<2>({ox, oy}));
  return (1 - wx) * (1 - wy) * v[c] + wx * (1 - wy) * v[nx] + (1 - wx) * wy * v[ny] + wx * wy * v[nxy];
}

struct CavityResult {
  double u_error = 0.0, v_error = 0.0;  // max deviation from Ghia on the centrelines
  double t = 0.0;
  Index leaves = 0;
  int steps = 0;
};

// Runs the cavity at Re on tree t until the velocity changes by less than `steady` per
// unit time (or t_max), then compares with Ghia's tables.
inline CavityResult run_cavity(tree::Tree<2>& t, double Re, double t_max, double steady, double adapt_tol = 0.0) {
  std::array<SideFlow<2>, 4> sides{};
  sides[3] = {.kind = SideKind::moving_wall, .velocity = {1.0, 0.0}};
  FlowOptions<2> o{.Re = Re, .dt = 0.02, .cfl = 0.8, .boundaries = sides};
  NavierStokes<2> ns(t, o);
  CavityResult r;
  std::vector<double> previous(t.num_cells(), 0.0);
  double last_check = 0.0;
  while (ns.time() < t_max) {
    if (adapt_tol > 0.0 && r.steps % 5 == 0) {
      (void)ns.adapt(adapt_tol, {.min_level = 4, .max_level = t.max_level()});
      previous.assign(t.num_cells(), 0.0);
    }
    (void)ns.step();
    ++r.steps;
    if (ns.time() - last_check >= 0.5 && adapt_tol == 0.0) {
      double change = 0.0;
      for (const auto c : t.leaves()) change = std::max(change, std::abs(ns.u(0)[c] - previous[c]));
      for (const auto c : t.leaves()) previous[c] = ns.u(0)[c];
      const double rate = change / (ns.time() - last_check);
      last_check = ns.time();
      if (rate < steady) break;
    }
  }
  r.t = ns.time();
  r.leaves = t.num_leaves();
  for (int d = 0; d < 2; ++d) t.sync(ns.velocity(d));
  const std::string re = std::to_string(static_cast<int>(Re));
  for (const auto& g : read_ghia("ghia_re" + re + "_u.csv"))
    r.u_error = std::max(r.u_error, std::abs(sample(t, ns.u(0), {0.5, std::clamp(g.coord, 1e-9, 1 - 1e-9)}) - g.value));
  for (const auto& g : read_ghia("ghia_re" + re + "_v.csv"))
    r.v_error = std::max(r.v_error, std::abs(sample(t, ns.u(1), {std::clamp(g.coord, 1e-9, 1 - 1e-9), 0.5}) - g.value));
  return r;
}

}  // namespace capsflow::fluid::testing
