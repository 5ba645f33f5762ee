#pragma once
// A spherical capsule (radius 1, neo-Hookean, 642 or 2562 P2 nodes, Ca = 1: time in mu a / G)
// given an l = 2 displacement about the x axis, e_r P2 n + e_t dP2/dtheta e_theta, in a
// periodic box at rest (Stokes, Re = 1e-5 unless said), stepped with the implicit coupling,
// BDF2 nodes and flow and two pressure iterations (cases/relaxation_small.toml's scheme). What
// the tests read: the nodes' velocity and displacement projected on the two modes, and the
// small-deformation theory's relaxation matrix M (docs/numerics.md, tools/small_deformation.py).
#include <Eigen/Dense>

#include <functional>
#include <utility>

#include "coupling_support.hpp"
#include "fluid/adaptation.hpp"

namespace capsflow::ibm::test {

// d(e_r, e_t)/dt = M (e_r, e_t) in units of G / (mu a), kappa = 3 (neo-Hookean).
inline Eigen::Matrix2d relaxation_matrix(double lam) {
  const double kappa = 3.0, d = (2 * lam + 3) * (19 * lam + 16);
  Eigen::Matrix2d m;
  m << -4 * kappa * (lam + 4), 12 * (kappa * lam + 4 * kappa - 6 * lam - 4), 2 * kappa * (7 * lam + 8),
      -2 * (21 * kappa * lam + 24 * kappa + 26 * lam + 24);
  return m / d;
}

// The two modes at the unit vector n: P2 n and dP2/dtheta e_theta (theta from the x axis).
inline std::pair<Eigen::Vector3d, Eigen::Vector3d> l2_modes(const Eigen::Vector3d& n) {
  const double c = n[0];
  return {0.5 * (3 * c * c - 1) * n, 3 * c * (Eigen::Vector3d::UnitX() - c * n)};
}

// The least-squares mode coefficients of a nodal field w (nodes at the reference sphere's x0).
inline Eigen::Vector2d mode_coefficients(const Eigen::Matrix3Xd& x0, const Eigen::Matrix3Xd& w) {
  Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  for (Eigen::Index i = 0; i < w.cols(); ++i) {
    const auto [radial, tangential] = l2_modes(x0.col(i).normalized());
    a(0, 0) += radial.dot(radial);
    a(0, 1) += radial.dot(tangential);
    a(1, 1) += tangential.dot(tangential);
    b[0] += radial.dot(w.col(i));
    b[1] += tangential.dot(w.col(i));
  }
  a(1, 0) = a(0, 1);
  return a.ldlt().solve(b);
}

struct L2Relaxation {
  double viscosity_ratio = 1.0;
  double Re = 1e-5;
  double box = 16.0;   // the periodic box's side, in radii
  int level = 7;       // dx = box / 2^level at the membrane
  int mesh_level = 3;  // 642 P2 nodes
  double dt = 5e-3;
  Eigen::Vector2d displacement{0.01, 0.0};  // (e_r, e_t) at t = 0
};

// Runs `steps` steps; after each, on_step(t, velocity, displacement) with the modes'
// coefficients of the nodes' mean velocity over the step and of their mid-step displacement.
inline void run_l2_relaxation(const L2Relaxation& r, int steps,
                              const std::function<void(double, const Eigen::Vector2d&, const Eigen::Vector2d&)>& on_step) {
  tree::Tree<3> t({.roots = {1, 1, 1}, .root_size = r.box, .origin = {-r.box / 2, -r.box / 2, -r.box / 2},
                   .periodic = {true, true, true}, .max_level = r.level});
  t.refine_to([](const tree::Box<3>&) { return 3; });
  fluid::FlowOptions<3> o{.Re = r.Re, .stokes = true, .dt = r.dt};
  for (auto& side : o.boundaries) side.kind = fluid::SideKind::periodic;
  o.projection.tolerance = o.viscous.tolerance = 1e-8;
  o.bdf2 = true;
  o.pressure_iterations = 2;
  o.current_force_in_viscous = true;
  fluid::NavierStokes<3> ns(t, o);
  CapsuleCoupling cc(ns, /*margin=*/4);
  fluid::Adaptation<3> adaptation(ns, {.enabled = true, .velocity_tolerance = 1e-2, .min_level = 3});
  adaptation.set_bodies(&cc);
  membrane::MembraneModel model(membrane::make_icosphere({.order = membrane::Order::p2, .level = r.mesh_level, .radius = 1.0}),
                                {.kind = membrane::LawKind::neo_hookean, .gs = shear_modulus(1.0, r.Re)});
  const Eigen::Matrix3Xd x0 = model.mesh().nodes;
  Eigen::Matrix3Xd x = x0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    const auto [radial, tangential] = l2_modes(x0.col(i).normalized());
    x.col(i) += r.displacement[0] * radial + r.displacement[1] * tangential;
  }
  cc.add_capsule(std::move(model), x);
  cc.set_node_scheme(NodeScheme::bdf2);
  cc.set_implicit({.enabled = true});
  if (r.viscosity_ratio != 1.0) {
    cc.set_inner_fluid(0, {.viscosity_ratio = r.viscosity_ratio, .density_ratio = 1.0});
    const double mu_out = 1.0 / r.Re;
    ns.set_properties([&cc, mu_out](const tree::Tree<3>&, std::span<double> rho, std::span<double> mu) {
      cc.inner_properties(1.0, mu_out, rho, mu);
    });
  }
  (void)adaptation.refine_initial();
  for (int s = 0; s < steps; ++s) {
    const Eigen::Matrix3Xd before = cc.capsule(0).x;
    (void)cc.step();  // the nodes move a hundredth of a cell: the first tree holds them
    const Eigen::Matrix3Xd& now = cc.capsule(0).x;
    on_step(ns.time(), mode_coefficients(x0, (now - before) / r.dt), mode_coefficients(x0, 0.5 * (now + before) - x0));
  }
}

}  // namespace capsflow::ibm::test
