#pragma once
// The coupled runs of the ibm tests: the seed channel (a 4 x 1 x 1 brick of side-2 roots:
// length 8, half-width 1; walls on the inlet x_lo and the lateral sides, outflow at x_hi)
// with one capsule, shrunk to a coarse tree.
#include <memory>

#include "fluid/navier_stokes.hpp"
#include "ibm/capsule_coupling.hpp"
#include "membrane/diagnostics.hpp"
#include "membrane/mesh.hpp"
#include "membrane/shapes.hpp"

namespace capsflow::ibm::test {

struct SeedRun {
  int max_level = 5;
  int min_level = 2;
  double dt = 1e-3;
  double Ca = 0.05, Re = 1.0;
  double radius = 0.85;
  bool stokes = true;
  bool ellipsoid = true;  // the seed's (2a, a/sqrt2, a/sqrt2); else the reference sphere
  membrane::Order order = membrane::Order::p2;
  int mesh_level = 3;     // 642 nodes
  double tolerance = 1e-6;  // multigrid tolerances (projection and viscosity)
  fluid::AdaptationOptions adapt{.enabled = true, .velocity_tolerance = 1e-2, .min_level = 2};
  int margin = 2;  // the band's cells beyond the kernels
  KernelChoice kernels{};
  bool crank_nicolson = false;  // viscous scheme (FlowOptions)
  bool current_force_in_viscous = false;  // FlowOptions
  bool carry_faces = false;               // FlowOptions
  bool bdf2 = false;                      // FlowOptions
};

struct SeedSetup {
  std::unique_ptr<tree::Tree<3>> tree;
  std::unique_ptr<fluid::NavierStokes<3>> ns;
  std::unique_ptr<CapsuleCoupling> coupling;
  std::unique_ptr<fluid::Adaptation<3>> adaptation;  // with the coupling's membrane bands

  // One coupled step, then the adapt stage (as capsflow run does); whether it adapted.
  bool step() {
    (void)coupling->step();
    return adaptation->after_step(coupling->steps());
  }
};

inline fluid::FlowOptions<3> seed_flow(const SeedRun& r) {
  fluid::FlowOptions<3> o{.Re = r.Re, .stokes = r.stokes, .dt = r.dt};
  for (auto& s : o.boundaries) s.kind = fluid::SideKind::wall;
  o.boundaries[1].kind = fluid::SideKind::outflow;  // x_hi
  o.projection.tolerance = r.tolerance;
  o.viscous.tolerance = r.tolerance;
  o.crank_nicolson = r.crank_nicolson;
  o.current_force_in_viscous = r.current_force_in_viscous;
  o.carry_faces = r.carry_faces;
  o.bdf2 = r.bdf2;
  return o;
}

inline SeedSetup seed_setup(const SeedRun& r) {
  SeedSetup s;
  s.tree = std::make_unique<tree::Tree<3>>(
      tree::TreeOptions<3>{.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = r.max_level});
  const int base = r.min_level;
  s.tree->refine_to([base](const tree::Box<3>&) { return base; });
  s.ns = std::make_unique<fluid::NavierStokes<3>>(*s.tree, seed_flow(r));
  s.coupling = std::make_unique<CapsuleCoupling>(*s.ns, r.margin);
  membrane::MembraneModel model(
      membrane::make_icosphere({.order = r.order, .level = r.mesh_level, .radius = r.radius}),
      {.kind = membrane::LawKind::skalak, .gs = shear_modulus(r.Ca, r.Re), .c = 1.0});
  Eigen::Matrix3Xd x = r.ellipsoid ? membrane::seed_ellipsoid(model.mesh().nodes, Eigen::Vector3d::Zero())
                                   : Eigen::Matrix3Xd(model.mesh().nodes);
  s.coupling->add_capsule(std::move(model), std::move(x), r.kernels);
  s.adaptation = std::make_unique<fluid::Adaptation<3>>(*s.ns, r.adapt);
  s.adaptation->set_bodies(s.coupling.get());
  (void)s.adaptation->refine_initial();
  return s;
}

// A triply periodic box [-1, 1]^3 at level 2 (max level 4: dx = 1/8 at the finest) and
// its flow (Re = 1, dt = 0.01): a capsule can be carried across every side.
struct PeriodicBox {
  static tree::Tree<3> make_tree() {
    tree::Tree<3> t({.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1},
                     .periodic = {true, true, true}, .max_level = 4});
    t.refine_to([](const tree::Box<3>&) { return 2; });
    return t;
  }
  static fluid::FlowOptions<3> flow(bool stokes, bool current_force_in_viscous = false) {
    fluid::FlowOptions<3> o{.Re = 1.0, .stokes = stokes, .dt = 0.01};
    o.current_force_in_viscous = current_force_in_viscous;
    for (auto& side : o.boundaries) side.kind = fluid::SideKind::periodic;
    return o;
  }
  explicit PeriodicBox(bool stokes, bool current_force_in_viscous = false)
      : ns(tree, flow(stokes, current_force_in_viscous)) {}

  tree::Tree<3> tree = make_tree();
  fluid::NavierStokes<3> ns;
};

// The same velocity u in every cell (leaves, parents, halos).
inline void set_uniform_velocity(fluid::NavierStokes<3>& ns, const Eigen::Vector3d& u) {
  for (Index c = 0; c < ns.tree().num_cells(); ++c)
    for (int d = 0; d < 3; ++d) ns.u(d)[c] = u[d];
}

// max |u| over the leaves.
inline double max_velocity(fluid::NavierStokes<3>& ns) {
  double m = 0.0;
  for (const Index c : ns.tree().leaves())
    m = std::max(m, std::sqrt(ns.u(0)[c] * ns.u(0)[c] + ns.u(1)[c] * ns.u(1)[c] + ns.u(2)[c] * ns.u(2)[c]));
  return m;
}

}  // namespace capsflow::ibm::test
