#pragma once
// Stokes flow through periodic arrays (embedded walls): the reference tables of tests/data and
// the steady drag of a simple cubic array of spheres (Zick & Homsy 1982).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "fluid/navier_stokes.hpp"
#include "flow_sides.hpp"

namespace capsflow::fluid::testing {

using tree::Index;
using tree::Tree;

// The second column of a table in tests/data (phi, value) at phi.
inline double reference(const char* file, double phi) {
  std::ifstream in(std::string(CAPSFLOW_REFERENCE_DIR) + "/" + file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 'p') continue;
    std::stringstream ss(line);
    double p = 0.0, drag = 0.0;
    char comma = 0;
    ss >> p >> comma >> drag;
    if (std::abs(p - phi) < 1e-12) return drag;
  }
  ADD_FAILURE() << "no reference value for phi = " << phi << " in " << file;
  return 0.0;
}

// The drag coefficient K = F / (6 pi mu a U) of a simple cubic array of spheres at volume
// fraction phi (F = G L^3, G = 1, L = 1), on a uniform tree of `level`, at the steady state.
inline double sphere_array_k(double phi, int level, double dt) {
  const double pi = std::acos(-1.0), radius = std::cbrt(3.0 * phi / (4.0 * pi));
  Tree<3> t({.roots = {1, 1, 1}, .periodic = {true, true, true}, .max_level = level});
  t.refine_to([level](const tree::Box<3>&) { return level; });
  FlowOptions<3> o{.Re = 1.0, .stokes = true, .dt = dt, .boundaries = all<3>(SideKind::periodic)};
  o.projection.tolerance = o.viscous.tolerance = 1e-9;
  o.projection.max_cycles = o.viscous.max_cycles = 100;
  NavierStokes<3> ns(t, o);
  ns.set_solid(geometry::sphere({0.5, 0.5, 0.5}, radius));
  ns.set_face_force([](const Tree<3>&, FaceField<3>& f) { std::fill(f[0].begin(), f[0].end(), 1.0); });
  auto superficial = [&] {  // the flux along x per unit area: each leaf's lower x face
    double q = 0.0;
    for (const Index c : t.leaves()) {
      const double h = t.cell_size(t.level_of(c));
      q += ns.face_velocity()[0][static_cast<std::size_t>(c)] * ns.embedded()->faces()[0][static_cast<std::size_t>(c)] * h * h * h;
    }
    return q;
  };
  double u = 0.0, previous = -1.0;
  int steps = 0;
  for (; steps < 5000 && std::abs(u - previous) > 1e-6 * dt * std::abs(u); ++steps) {
    EXPECT_TRUE(ns.step().converged);
    previous = u;
    u = superficial();
  }
  const double k = 1.0 / (6.0 * pi * radius * u);
  std::printf("spheres phi %.3f level %d (a/h = %.1f): K %.4f after %d steps, Zick & Homsy %.3f\n", phi, level,
              radius * std::pow(2.0, level), k, steps, reference("zick_homsy_cubic_spheres.csv", phi));
  return k;
}

}  // namespace capsflow::fluid::testing
