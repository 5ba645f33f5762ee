// Coupled capsule runs on the seed channel shrunk to seconds: no spurious motion at rest,
// exact translation with a uniform flow across periodic sides, the quick Stokes relaxation
// of the seed's ellipsoid, and the blow-up and missing-refinement errors.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>

#include <fmt/format.h>

#include "coupling_support.hpp"

namespace capsflow::ibm {
namespace {

using test::SeedRun;

// Index of the mirror image of each node under x_d -> -x_d (the icosphere's coordinate
// planes are symmetry planes of the mesh).
std::vector<Eigen::Index> mirror_pairs(const Eigen::Matrix3Xd& x0, int d) {
  std::vector<Eigen::Index> m(static_cast<std::size_t>(x0.cols()), -1);
  for (Eigen::Index i = 0; i < x0.cols(); ++i) {
    Eigen::Vector3d image = x0.col(i);
    image[d] = -image[d];
    for (Eigen::Index j = 0; j < x0.cols(); ++j)
      if ((x0.col(j) - image).norm() < 1e-12) m[i] = j;
  }
  return m;
}

double mirror_error(const Eigen::Matrix3Xd& x, const std::vector<Eigen::Index>& m, int d) {
  double worst = 0.0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    Eigen::Vector3d image = x.col(m[i]);
    image[d] = -image[d];
    worst = std::max(worst, (x.col(i) - image).norm());
  }
  return worst;
}

// An unstressed capsule (the reference sphere) in fluid at rest: its forces vanish to
// round-off, so nothing may move.
TEST(Coupling, UnstressedCapsuleAtRestStaysAtRest) {
  // (radius 0.75, dx = 1/16: the divergence-free cosine stencil reaches 3 cells.)
  SeedRun r{.max_level = 5, .radius = 0.75, .ellipsoid = false};
  auto s = test::seed_setup(r);
  const Eigen::Matrix3Xd x0 = s.coupling->capsule(0).x;
  double worst_u = 0.0;
  for (int k = 0; k < 30; ++k) {
    (void)s.step();
    worst_u = std::max(worst_u, test::max_velocity(*s.ns));
  }
  const double moved = membrane::max_node_distance(s.coupling->capsule(0).x, x0);
  const double fmax = s.coupling->capsule(0).forces.colwise().norm().maxCoeff();
  std::printf("at rest, 30 steps: max |F| %.2e, max |u| %.2e, max node displacement %.2e\n", fmax, worst_u, moved);
  EXPECT_LT(fmax, 1e-12);
  EXPECT_LT(worst_u, 1e-12);
  EXPECT_LT(moved, 1e-14);
}

// A prestressed capsule (the reference sphere inflated by 2 %) in fluid at rest: the exact
// state is rest with a pressure jump across the membrane. The spread force is a sum of
// smoothed normal point forces, not an exact discrete gradient, so the IBM leaves small
// spurious currents; they must stay small and must not move the capsule.
TEST(Coupling, PrestressedCapsuleAtRestBarelyMoves) {
  SeedRun r{.max_level = 5, .radius = 0.75, .ellipsoid = false};
  auto s = test::seed_setup(r);
  Capsule& c = s.coupling->capsule(0);
  c.x = membrane::inflate(c.model.mesh().nodes, 1.02, Eigen::Vector3d::Zero());
  const Eigen::Matrix3Xd x0 = c.x;
  const auto d0 = membrane::shape_diagnostics(c.model.mesh(), x0);
  double worst_u = 0.0;
  for (int k = 0; k < 50; ++k) {
    (void)s.step();
    worst_u = std::max(worst_u, test::max_velocity(*s.ns));
  }
  const auto d = membrane::shape_diagnostics(c.model.mesh(), c.x);
  const double fmax = c.forces.colwise().norm().maxCoeff();
  std::printf("prestressed at rest, 50 steps: max |F| %.2e, max |u| %.2e (last %.2e), max node displacement %.2e, "
              "centroid %.1e, volume_rel %.2e\n",
              fmax, worst_u, test::max_velocity(*s.ns), membrane::max_node_distance(c.x, x0), d.centroid.norm(),
              (d.volume - d0.volume) / d0.volume);
  // Scales: the isotropic Skalak tension T = Gs [l^2 - 1 + C l^2 (l^4 - 1)] = 2.52 at
  // l = 1.02, velocity scale T / mu = 2.52; measured (radius 0.75, divergence-free kernels)
  // max |u| = 0.026 (1 % of it), node displacement 9.1e-4 (0.015 dx), volume leak 0.10 %
  // over t = 0.05.
  const double l2 = 1.02 * 1.02, tension = shear_modulus(r.Ca, r.Re) * (l2 - 1 + l2 * (l2 * l2 - 1));
  EXPECT_LT(worst_u, 0.02 * tension * r.Re);
  EXPECT_LT(membrane::max_node_distance(c.x, x0), 0.05 / 16);
  EXPECT_LT(d.centroid.norm(), 1e-6);
  EXPECT_LT(std::abs(d.volume - d0.volume) / d0.volume, 2e-3);
}

// A uniform flow in a triply periodic box carries an unstressed capsule with it, across
// the periodic sides (unwrapped positions, wrapped stencils, tags and adaptation moving
// with it), without deforming: the interpolation of a uniform field is exact (weights sum
// to 1) and the flow stays uniform (the spread force is zero to round-off).
TEST(Coupling, UniformFlowCarriesCapsuleAcrossPeriodicSides) {
  test::PeriodicBox box(/*stokes=*/false);
  fluid::NavierStokes<3>& ns = box.ns;
  CapsuleCoupling cc(ns);
  fluid::Adaptation<3> adaptation(ns, {.enabled = true, .velocity_tolerance = 1e-2, .min_level = 2});
  adaptation.set_bodies(&cc);
  membrane::MembraneModel model(membrane::make_icosphere({.level = 3, .radius = 0.4}),
                                {.gs = shear_modulus(0.1, 1.0)});
  const Eigen::Matrix3Xd x0 = model.mesh().nodes.colwise() + Eigen::Vector3d(0.5, 0.0, -0.3);
  cc.add_capsule(std::move(model), x0);
  (void)adaptation.refine_initial();
  const Eigen::Vector3d u(1.5, -0.5, 0.25);
  test::set_uniform_velocity(ns, u);
  for (int k = 0; k < 60; ++k) {
    (void)cc.step();
    (void)adaptation.after_step(cc.steps());
  }
  const Eigen::Matrix3Xd expected = x0.colwise() + u * ns.time();
  const double error = membrane::max_node_distance(cc.capsule(0).x, expected);
  std::printf("uniform flow: t = %.2f, centre moved by (%.2f, %.2f, %.2f), max node error %.2e\n", ns.time(),
              u[0] * ns.time(), u[1] * ns.time(), u[2] * ns.time(), error);
  EXPECT_GT(cc.capsule(0).x.row(0).maxCoeff(), 1.0);  // crossed x_hi
  EXPECT_LT(error, 1e-12);
  // Its volume, with the default (divergence-free) kernels, to round-off.
  const auto& mesh = cc.capsule(0).model.mesh();
  const double v0 = membrane::enclosed_volume(mesh, x0);
  const double v = membrane::enclosed_volume(mesh, cc.capsule(0).x);
  std::printf("uniform flow: volume_rel %.1e\n", (v - v0) / v0);
  EXPECT_LT(std::abs(v - v0) / v0, 1e-13);
}

// A capsule in a steady cellular flow, u = (sin(pi x) cos(pi y), -cos(pi x) sin(pi y), 0),
// held against viscosity by the body force 2 pi^2 mu u in the triply periodic box [-1, 1]^3
// (uniform dx = 1/8, Stokes, Re = 1, 642 P2 nodes, radius 0.35): centred on the vortex at
// (1/2, 1/2, 0) it turns at angular velocity pi (half a turn by t = 1) while the vortex's
// strain deforms it. Its volume changes only through the node velocity's divergence and the
// time integration: forward Euler in a rotation gains (omega dt)^2 per step (measured
// +3.8% over one turn at dt = 4e-3, whatever the interpolation), so the nodes move by the
// midpoint scheme here, whose error per step is O((omega dt)^3). Measured after half a turn
// (t = 1): volume_rel -1.65e-5 with the divergence-free kernels, -1.8e-3 on faces without
// them, -3.7e-3 on cells; after a full turn -4.8e-7, -4.0e-3 and -7.9e-3: with the
// divergence-free form the change follows the shape (the P2 surface through nodes that stay
// on a volume-preserving material surface) and returns, the others accumulate.
double cellular_flow_volume(KernelChoice kernels, NodeScheme scheme) {
  tree::Tree<3> t({.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .periodic = {true, true, true},
                   .max_level = 4});
  t.refine_to([](const tree::Box<3>&) { return 4; });
  fluid::FlowOptions<3> o{.Re = 1.0, .stokes = true, .dt = 4e-3};
  for (auto& side : o.boundaries) side.kind = fluid::SideKind::periodic;
  fluid::NavierStokes<3> ns(t, o);
  const double pi = std::acos(-1.0);
  auto cellular = [pi](int d, double x, double y) {
    return d == 0 ? std::sin(pi * x) * std::cos(pi * y) : d == 1 ? -std::cos(pi * x) * std::sin(pi * y) : 0.0;
  };
  for (const Index c : t.leaves()) {
    const auto p = t.center(c);
    for (int d = 0; d < 3; ++d) ns.u(d)[c] = cellular(d, p[0], p[1]);
  }
  CapsuleCoupling cc(ns);
  cc.set_background_force([&](const tree::Tree<3>& tree, fluid::FaceField<3>& f) {
    const double h = tree.cell_size(4);
    for (const Index c : tree.leaves()) {
      const auto p = tree.center(c);
      f[0][c] = 2 * pi * pi * cellular(0, p[0] - 0.5 * h, p[1]);
      f[1][c] = 2 * pi * pi * cellular(1, p[0], p[1] - 0.5 * h);
      f[2][c] = 0.0;
    }
  });
  membrane::MembraneModel model(membrane::make_icosphere({.order = membrane::Order::p2, .level = 3, .radius = 0.35}),
                                {.kind = membrane::LawKind::neo_hookean, .gs = shear_modulus(0.2, 1.0)});
  const Eigen::Matrix3Xd x0 = model.mesh().nodes.colwise() + Eigen::Vector3d(0.5, 0.5, 0.0);
  const double v0 = membrane::enclosed_volume(model.mesh(), x0);
  cc.add_capsule(std::move(model), x0, kernels);
  cc.set_node_scheme(scheme);
  for (int k = 0; k < 250; ++k) (void)cc.step();
  const Capsule& c = cc.capsule(0);
  const auto d = membrane::shape_diagnostics(c.model.mesh(), c.x);
  std::printf("cellular flow, t = %.2f (half a turn), staggered %d, divergence-free %d, scheme %d: D12 %.3f, volume_rel %.2e\n",
              ns.time(), kernels.staggered, kernels.divergence_free, static_cast<int>(scheme), d.d12, (d.volume - v0) / v0);
  return (d.volume - v0) / v0;
}

TEST(Coupling, CellularFlowKeepsTheVolumeWithDivergenceFreeKernels) {
  const KernelChoice cosine{.spread = KernelKind::cosine, .interpolate = KernelKind::cosine};
  KernelChoice faces = cosine, cells = cosine;
  faces.divergence_free = false;
  cells.staggered = false;
  const double free = cellular_flow_volume(cosine, NodeScheme::midpoint),
               on_faces = cellular_flow_volume(faces, NodeScheme::midpoint),
               on_cells = cellular_flow_volume(cells, NodeScheme::midpoint);
  // What remains with the divergence-free form is the P2 surface's error for the current
  // shape (and O((omega dt)^3) per step): bounded by 5e-5 here, 20 times below the others.
  EXPECT_LT(std::abs(free), 5e-5);
  EXPECT_LT(std::abs(free), std::abs(on_faces) / 20);
  EXPECT_GT(std::abs(on_faces), 1e-3);
  EXPECT_GT(std::abs(on_cells), 1e-3);
}

// The midpoint scheme takes u^n from the faces at the start of a step. An adaptation rebuilds
// the tree; the faces used to restart from the face mean of the cell velocity, which is not
// divergence-free, and each step after an adaptation lost volume (the seed's ellipsoid,
// dx = 1/16, 10 242 nodes, adapting every 5 steps, 6 rebuilds in 30 steps: up to 6.3e-5 in
// a step after one, -2.5e-4 after 30 steps, against at most 8e-7 in the other steps). The
// flow now keeps the projected faces wherever the cells on both sides did not change,
// which covers the membrane band: measured -3.3e-6 after 30 steps, at most 1.0e-6 in a
// step after an adaptation.
TEST(Coupling, MidpointKeepsTheVolumeThroughAdaptations) {
  SeedRun r{.max_level = 5, .dt = 1e-3, .mesh_level = 5};
  r.adapt.interval = 5;
  r.adapt.velocity_tolerance = 1e-3;
  auto s = test::seed_setup(r);
  s.coupling->set_node_scheme(NodeScheme::midpoint);
  const auto& mesh = s.coupling->capsule(0).model.mesh();
  const double v0 = membrane::enclosed_volume(mesh, s.coupling->capsule(0).x);
  double v = v0, worst_after_adapt = 0.0, worst_other = 0.0;
  bool after_adapt = false;
  int rebuilt = 0;
  for (int k = 0; k < 30; ++k) {
    const Index cells = s.tree->num_cells();
    const bool adapted = s.step();
    const double vn = membrane::enclosed_volume(mesh, s.coupling->capsule(0).x);
    double& worst = after_adapt ? worst_after_adapt : worst_other;
    worst = std::max(worst, std::abs(vn - v) / v0);
    v = vn;
    after_adapt = adapted && s.tree->num_cells() != cells;
    if (after_adapt) {
      ++rebuilt;
      EXPECT_TRUE(s.ns->face_velocity_carried()) << "step " << k + 1;
    }
  }
  std::printf("midpoint through %d rebuilding adaptations: volume_rel %+.2e after 30 steps, largest step change "
              "%.1e after an adaptation, %.1e otherwise\n",
              rebuilt, (v - v0) / v0, worst_after_adapt, worst_other);
  EXPECT_GE(rebuilt, 4);
  EXPECT_LT(std::abs(v - v0) / v0, 1e-5);
  EXPECT_LT(worst_after_adapt, 2e-6);
}

// adapt.max_interval: an adaptation due every `interval` steps waits while the nodes, at
// their mean speed since the last one, would stay within half the band's margin until
// max_interval steps have passed; it never waits longer. Three speeds in a periodic box
// (dx = 1/8, margin 2 cells: half the margin is 0.125): at rest and slow (0.2 dt 8 = 0.016)
// it adapts every 8th step; fast (3.2 dt 8 = 0.26) every step, as without max_interval.
TEST(Coupling, AdaptationWaitsOnlyWhileNodesAreSlow) {
  for (const double speed : {0.0, 0.2, 3.2}) {
    test::PeriodicBox box(/*stokes=*/false);
    fluid::NavierStokes<3>& ns = box.ns;
    CapsuleCoupling cc(ns, /*margin=*/2);
    fluid::Adaptation<3> adaptation(
        ns, {.enabled = true, .interval = 1, .max_interval = 8, .velocity_tolerance = 1e-2, .min_level = 2});
    adaptation.set_bodies(&cc);
    membrane::MembraneModel model(membrane::make_icosphere({.level = 3, .radius = 0.4}),
                                  {.gs = shear_modulus(0.1, 1.0)});
    const Eigen::Matrix3Xd x0 = model.mesh().nodes;
    cc.add_capsule(std::move(model), x0);
    (void)adaptation.refine_initial();
    const Eigen::Vector3d u = speed * Eigen::Vector3d(0.8, 0.6, 0.0);
    test::set_uniform_velocity(ns, u);
    std::vector<int> adapted;
    for (int k = 1; k <= 24; ++k) {
      (void)cc.step();
      if (adaptation.after_step(cc.steps())) adapted.push_back(k);
    }
    const double error = membrane::max_node_distance(cc.capsule(0).x, x0.colwise() + u * ns.time());
    std::printf("speed %.1f: %zu adaptations in 24 steps, max node error %.1e\n", speed, adapted.size(), error);
    if (speed < 1.0) {
      EXPECT_EQ(adapted, (std::vector<int>{8, 16, 24})) << "speed " << speed;
    } else {
      EXPECT_EQ(adapted.size(), 24u);
    }
    EXPECT_LT(error, 1e-12) << "every stencil found its cells: the band moved with the capsule";
    EXPECT_EQ(cc.steps_since_adapt(), 0);
  }
}

// A background body force (here uniform, in a periodic box) acts together with the
// capsules' force: the fluid accelerates uniformly, u = g t, and an unstressed capsule
// follows it: X = X0 + g dt^2 n (n + 1) / 2 after n steps.
TEST(Coupling, BackgroundForceActsWithTheCapsules) {
  test::PeriodicBox box(/*stokes=*/true);
  fluid::NavierStokes<3>& ns = box.ns;
  CapsuleCoupling cc(ns);
  fluid::Adaptation<3> adaptation(ns, {.enabled = true, .min_level = 2});
  adaptation.set_bodies(&cc);
  membrane::MembraneModel model(membrane::make_icosphere({.level = 3, .radius = 0.4}), {.gs = 10.0});
  const Eigen::Matrix3Xd x0 = model.mesh().nodes;
  cc.add_capsule(std::move(model), x0);
  (void)adaptation.refine_initial();
  const Eigen::Vector3d g(0.5, 0.0, -1.0);
  cc.set_background_force([&](const tree::Tree<3>&, fluid::FaceField<3>& faces) {
    for (int d = 0; d < 3; ++d) std::fill(faces[d].begin(), faces[d].end(), g[d]);
  });
  const int n = 20;
  for (int k = 0; k < n; ++k) {
    (void)cc.step();
    (void)adaptation.after_step(cc.steps());
  }
  const Eigen::Matrix3Xd expected = x0.colwise() + g * (0.01 * 0.01 * n * (n + 1) / 2.0);
  EXPECT_LT(membrane::max_node_distance(cc.capsule(0).x, expected), 1e-12);
  EXPECT_NEAR(test::max_velocity(ns), g.norm() * ns.time(), 1e-12);
}

struct Relaxation {
  std::vector<double> t, d12, volume_rel, centroid, mirror, roundness;
  double seconds = 0.0;
  StageTimes stages;
  double adapt_seconds = 0.0;
  Index max_leaves = 0;
};

Relaxation relax(const SeedRun& r, int steps) {
  const auto t0 = std::chrono::steady_clock::now();
  auto s = test::seed_setup(r);
  CapsuleCoupling& cc = *s.coupling;
  const auto& mesh = cc.capsule(0).model.mesh();
  const auto my = mirror_pairs(mesh.nodes, 1), mz = mirror_pairs(mesh.nodes, 2);
  const double v0 = membrane::shape_diagnostics(mesh, mesh.nodes).volume;  // the reference sphere
  Relaxation out;
  auto record = [&](double time) {
    const auto d = membrane::shape_diagnostics(mesh, cc.capsule(0).x);
    out.t.push_back(time);
    out.d12.push_back(d.d12);
    out.volume_rel.push_back((d.volume - v0) / v0);
    out.centroid.push_back(d.centroid.norm());
    out.mirror.push_back(std::max(mirror_error(cc.capsule(0).x, my, 1), mirror_error(cc.capsule(0).x, mz, 2)));
    out.roundness.push_back(std::abs(d.semi_axes[1] - d.semi_axes[2]) / d.semi_axes[1]);
  };
  record(0.0);
  for (int k = 0; k < steps; ++k) {
    const auto st = cc.step();
    EXPECT_TRUE(st.fluid.converged) << "step " << k + 1;
    (void)s.adaptation->after_step(cc.steps());
    record(st.fluid.t);
    out.max_leaves = std::max(out.max_leaves, s.tree->num_leaves());
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.stages = cc.times();
  out.adapt_seconds = s.adaptation->seconds();
  return out;
}

// The seed's relaxation case on a coarse tree: the 4 x 1 x 1 channel, Ca = 0.05, Re = 1
// (unsteady Stokes), Skalak C = 1, the ellipsoid (2a, a/sqrt2, a/sqrt2), a = 0.85, max level
// 5 (dx = 1/16), dt = 1e-3 (a third of the stability scale Ca dx = 3.1e-3), 300 steps.
// Mesh: 2562 P2 nodes (h/dx = 1.1 on the sphere, the seed's ideal ratio being 1.25). The
// 642-node mesh is too coarse for dx = 1/16 (h/dx = 2.2, 4.5 along the stretched axis, where
// the seed already calls h/dx = 2.5 too coarse): its membrane leaks, D12 first rises by
// 3e-4 over 4 steps and the volume drops by 0.9 % by t = 0.3.
TEST(Coupling, QuickStokesRelaxation) {
  const SeedRun r{.max_level = 5, .dt = 1e-3, .mesh_level = 4};
  const Relaxation run = relax(r, 300);
  std::printf("quick relaxation: %.1f s (membrane %.2f, spreading %.2f, fluid %.2f, interpolation %.2f, adapt %.2f)\n",
              run.seconds, run.stages.membrane, run.stages.spreading, run.stages.fluid, run.stages.interpolation,
              run.adapt_seconds);
  double worst_volume = 0.0, worst_centroid = 0.0, worst_mirror = 0.0, worst_round = 0.0;
  for (std::size_t k = 0; k < run.t.size(); ++k) {
    if (k % 50 == 0)
      std::printf("  t = %.3f  D12 = %.5f  volume_rel = %+.2e  |centroid| = %.1e  mirror = %.1e\n", run.t[k],
                  run.d12[k], run.volume_rel[k], run.centroid[k], run.mirror[k]);
    if (k > 0) {
      EXPECT_LT(run.d12[k], run.d12[k - 1]) << "D12 must decrease at every step: step " << k;
    }
    worst_volume = std::max(worst_volume, std::abs(run.volume_rel[k]));
    worst_centroid = std::max(worst_centroid, run.centroid[k]);
    worst_mirror = std::max(worst_mirror, run.mirror[k]);
    worst_round = std::max(worst_round, run.roundness[k]);
  }
  std::printf("  max |volume_rel| %.2e, max |centroid| %.1e, max mirror error %.1e, max |L2 - L3|/L2 %.1e\n",
              worst_volume, worst_centroid, worst_mirror, worst_round);
  // It relaxes: from the seed's 0.478 to below 0.2 by t = 0.3.
  EXPECT_NEAR(run.d12.front(), 0.4776, 1e-3);
  EXPECT_LT(run.d12.back(), 0.2);
  // The channel is symmetric about y = 0 and z = 0 and so are the mesh and the tree: the
  // capsule stays centred and mirror-symmetric node by node, up to the multigrid
  // tolerance (1e-6; the smoother's ordering is not symmetric). Along x the inlet wall
  // and the outflow differ, 3.4 half-lengths away: the drift is of the same tiny order.
  EXPECT_LT(worst_centroid, 1e-5);
  EXPECT_LT(worst_mirror, 1e-5);
  // The cross-section stays round: only the icosahedral mesh distinguishes y from z.
  EXPECT_LT(worst_round, 2e-3);
  // Volume: the seed's acceptance criterion (1 %, for dx = 1/32 to t = 10) holds here on a
  // grid twice as coarse: the IBM's volume error comes from the interpolated velocity not
  // being divergence-free, O(dx^2) (0.55 % here, 2.2 % at dx = 1/8 with the 642-node mesh).
  EXPECT_LT(worst_volume, 1e-2);
}

// The membrane-driven adaptation changes the answer only within the wavelet tolerance: the
// same case (100 steps, to t = 0.1) on the uniform level-5 grid and on the adaptive one.
// The wavelet tolerance 1e-2 on velocities of about 5 allows relative velocity errors of
// order 2e-3 away from the membrane band (which is at the max level in both), so D12, an
// integral of the velocity over the relaxation (0.478 -> 0.355 here), may differ by a few
// 1e-4: the bound is 1e-3.
TEST(Coupling, AdaptiveRelaxationMatchesUniform) {
  const SeedRun adaptive{.max_level = 5, .dt = 1e-3, .mesh_level = 4};
  SeedRun uniform = adaptive;
  uniform.min_level = uniform.adapt.min_level = 5;
  const Relaxation a = relax(adaptive, 100), u = relax(uniform, 100);
  double worst = 0.0;
  for (std::size_t k = 0; k < a.d12.size(); ++k) worst = std::max(worst, std::abs(a.d12[k] - u.d12[k]));
  std::printf("adaptive vs uniform to t = 0.1: max |dD12| %.2e (D12 %.5f vs %.5f), leaves <= %d vs %d, %.1f s vs %.1f s\n",
              worst, a.d12.back(), u.d12.back(), a.max_leaves, u.max_leaves, a.seconds, u.seconds);
  EXPECT_LT(worst, 1e-3);
  EXPECT_EQ(u.max_leaves, 4 << 15);
  EXPECT_LT(a.max_leaves, u.max_leaves * 2 / 3);
}

// Steps far above the membrane stability scale make the explicit coupling blow up; the run
// stops with the step, the time and the likely cause, and the positions of the last good step.
TEST(Coupling, BlowUpIsReportedWithItsLikelyCause) {
  SeedRun r{.max_level = 4, .dt = 2.5e-2, .radius = 0.6, .mesh_level = 3};
  auto s = test::seed_setup(r);
  Eigen::Matrix3Xd last_good = s.coupling->capsule(0).x;
  std::string message;
  int steps = 0;
  try {
    for (; steps < 50; ++steps) {
      (void)s.step();
      last_good = s.coupling->capsule(0).x;
    }
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  std::printf("%s\n", message.c_str());
  ASSERT_FALSE(message.empty()) << "no blow-up in 50 steps of dt = 4 Ca dx";
  using ::testing::HasSubstr;
  EXPECT_THAT(message, HasSubstr(fmt::format("step {} (t = ", steps + 1)));
  // The measured limit of this capsule: min(0.53 sqrt(dx^3 / Gs), 0.42 mu dx / Gs).
  const double gs = shear_modulus(r.Ca, r.Re), dx = 0.125;
  const double limit = std::min(0.53 * std::sqrt(dx * dx * dx / gs), 0.42 * dx / r.Re / gs);
  EXPECT_DOUBLE_EQ(s.coupling->stability_limit(), limit);
  EXPECT_THAT(message, HasSubstr(fmt::format("membrane stability limit of the explicit coupling, measured {:.3g}", limit)));
  EXPECT_EQ(membrane::max_node_distance(s.coupling->capsule(0).x, last_good), 0.0);
}

// Issue 31: a run whose first symptom is a node leaving the refined band (a capsule carried
// by a uniform flow across the periodic box, the adaptation never run after the first
// refinement, so nothing follows the nodes): the message names the node, the band, the time
// step, the measured limit and the keys, and no internal name. Above the limit it names the
// instability (unstable nodes leave the band first), below it the band's margin.
TEST(Coupling, NodeLeavingTheBandNamesTheTimeStepAndTheLimit) {
  for (const double dt : {0.005, 0.002}) {  // the limit here is 2.62e-3
    tree::Tree<3> t({.roots = {1, 1, 1}, .root_size = 2.0, .origin = {-1, -1, -1}, .periodic = {true, true, true},
                     .max_level = 5});  // dx = 1/16: the band covers part of the box only
    t.refine_to([](const tree::Box<3>&) { return 2; });
    fluid::FlowOptions<3> o = test::PeriodicBox::flow(/*stokes=*/true);
    o.dt = dt;
    fluid::NavierStokes<3> ns(t, o);
    CapsuleCoupling cc(ns);
    fluid::Adaptation<3> adaptation(ns, {.enabled = true, .velocity_tolerance = 1e-2, .min_level = 2});
    adaptation.set_bodies(&cc);
    membrane::MembraneModel model(membrane::make_icosphere({.level = 3, .radius = 0.2}), {.gs = shear_modulus(0.1, 1.0)});
    const Eigen::Matrix3Xd x0 = model.mesh().nodes;
    cc.add_capsule(std::move(model), x0);
    (void)adaptation.refine_initial();
    for (Index c = 0; c < t.num_cells(); ++c) ns.u(0)[c] = 1.5;
    std::string message;
    try {
      for (int k = 0; k < 100; ++k) (void)cc.step();
    } catch (const std::runtime_error& e) {
      message = e.what();
    }
    std::printf("dt = %g: %s\n", dt, message.c_str());
    using ::testing::HasSubstr;
    ASSERT_THAT(message, HasSubstr("is outside the band refined to level 5 around the membrane (the grid there is of level"));
    EXPECT_THAT(message, ::testing::Not(HasSubstr("::")));
    const double limit = cc.stability_limit();
    EXPECT_NEAR(limit, 0.53 * std::sqrt(0.1 / (16.0 * 16.0 * 16.0)), 1e-15);
    if (dt > limit) {
      EXPECT_THAT(message, HasSubstr(fmt::format("Likely cause: dt = {:.3g} above the membrane stability limit of the "
                                                 "explicit coupling, measured {:.3g} here",
                                                 dt, limit)));
      EXPECT_THAT(message, HasSubstr("lower time.dt, or set time.cfl > 0"));
    } else {
      EXPECT_THAT(message, HasSubstr(fmt::format("dt = {:.3g} is below the measured stability limit", dt)));
      EXPECT_THAT(message, HasSubstr("adapt.membrane_band"));
    }
  }
}

// Issue 31: a capsule carried by a fast, stable uniform flow several max-level cells per
// adaptation interval (0.12 dx a step, 30 steps between scheduled adaptations, a band margin
// of 2 cells): the adaptation follows it before the interval (BodyRefinement::must_adapt),
// so it crosses the periodic box with its band kept and without deforming.
TEST(Coupling, FastCapsuleKeepsItsBandWhateverTheAdaptationInterval) {
  test::PeriodicBox box(/*stokes=*/false);
  fluid::NavierStokes<3>& ns = box.ns;
  CapsuleCoupling cc(ns);
  fluid::Adaptation<3> adaptation(ns, {.enabled = true, .interval = 30, .velocity_tolerance = 1e-2, .min_level = 2});
  adaptation.set_bodies(&cc);
  membrane::MembraneModel model(membrane::make_icosphere({.level = 3, .radius = 0.4}),
                                {.gs = shear_modulus(0.1, 1.0)});
  const Eigen::Matrix3Xd x0 = model.mesh().nodes.colwise() + Eigen::Vector3d(0.5, 0.0, -0.3);
  cc.add_capsule(std::move(model), x0);
  (void)adaptation.refine_initial();
  const Eigen::Vector3d u(1.5, -0.5, 0.25);
  test::set_uniform_velocity(ns, u);
  for (int k = 0; k < 90; ++k) {
    (void)cc.step();
    (void)adaptation.after_step(cc.steps());
    ASSERT_TRUE(cc.stencils_ready()) << "step " << k + 1;
  }
  const double error = membrane::max_node_distance(cc.capsule(0).x, x0.colwise() + u * ns.time());
  std::printf("fast capsule: moved %.2f max-level cells along x in 90 steps, %lld adaptations (%lld before their "
              "interval of 30 steps), max node error %.1e\n",
              u[0] * ns.time() / 0.125, static_cast<long long>(adaptation.count()),
              static_cast<long long>(adaptation.forced_by_bodies()), error);
  EXPECT_GE(adaptation.forced_by_bodies(), 3);
  EXPECT_LT(error, 1e-12);
}

// Without the membrane-driven refinement the first spreading finds no max-level cells.
TEST(Coupling, MissingRefinementIsReported) {
  SeedRun r{.max_level = 4, .mesh_level = 3};
  tree::Tree<3> t({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 4});
  t.refine_to([](const tree::Box<3>&) { return 2; });
  fluid::NavierStokes<3> ns(t, test::seed_flow(r));
  CapsuleCoupling cc(ns);
  membrane::MembraneModel model(membrane::make_icosphere({.level = 3, .radius = 0.85}), {.gs = 20});
  Eigen::Matrix3Xd x = membrane::seed_ellipsoid(model.mesh().nodes, Eigen::Vector3d::Zero());
  cc.add_capsule(std::move(model), std::move(x));
  EXPECT_FALSE(cc.stencils_ready());
  try {
    (void)cc.step();
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("step 1 (t = 0): capsule 0: node 0 at ("));
    EXPECT_THAT(e.what(), ::testing::HasSubstr("is outside the band refined to level 4 around the membrane (the grid there "
                                               "is coarser). Likely cause: dt = "));
    EXPECT_THAT(e.what(), ::testing::Not(::testing::HasSubstr("::"))) << "no internal names";
  }
  fluid::Adaptation<3> adaptation(ns, {.min_level = 0});
  adaptation.set_bodies(&cc);
  (void)adaptation.refine_initial();
  EXPECT_TRUE(cc.stencils_ready());
}

// The forced levels of the adapt stage: the membrane band at the max level, walls (the
// no-slip sides, not the outflow) at theirs.
TEST(Coupling, RequiredLevelsOfWallsAndMembrane) {
  SeedRun r{.max_level = 4, .mesh_level = 3};
  tree::Tree<3> t({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 4});
  fluid::NavierStokes<3> ns(t, test::seed_flow(r));
  CapsuleCoupling cc(ns);
  fluid::Adaptation<3> adaptation(ns, {.min_level = 0, .wall_level = 3});
  adaptation.set_bodies(&cc);
  cc.add_capsule(membrane::MembraneModel(membrane::make_icosphere({.level = 3, .radius = 0.5}), {.gs = 20}),
                 membrane::make_icosphere({.level = 3, .radius = 0.5}).nodes);
  (void)adaptation.refine_initial();
  const double h = 2.0 / 16;
  auto box = [&](double x, double y, double z, double size) {
    return tree::Box<3>{{x, y, z}, {x + size, y + size, z + size}};
  };
  EXPECT_EQ(adaptation.required_level(box(2.0, -1.0, 0.0, 2 * h)), 3);      // on the wall y_lo
  EXPECT_EQ(adaptation.required_level(box(-4.0, 0.25, 0.25, 2 * h)), 3);     // on the inlet wall x_lo
  EXPECT_EQ(adaptation.required_level(box(4.0 - 2 * h, 0.25, 0.25, 2 * h)), 0);  // the outflow x_hi
  EXPECT_EQ(adaptation.required_level(box(0.5, 0.0, 0.0, h)), 4);            // on the membrane
  EXPECT_EQ(adaptation.required_level(box(2.0, 0.0, 0.0, h)), 0);            // neither
  // After the initial refinement every wall leaf is at level 3 at least.
  for (const Index c : t.leaves()) {
    const tree::Box<3> b = t.box(c);
    if (b.lo[1] <= -1.0 + 1e-12) {
      ASSERT_GE(t.level_of(c), 3);
    }
  }
}

// The partition weight of a leaf (N ranks): the max-level leaves of the band the last
// adaptation refined weigh what they are given, every other leaf 1.
TEST(Coupling, BandLeavesWeighTheirMembraneWork) {
  SeedRun r{.max_level = 4, .mesh_level = 3};
  tree::Tree<3> t({.roots = {4, 1, 1}, .root_size = 2.0, .origin = {-4, -1, -1}, .max_level = 4});
  fluid::NavierStokes<3> ns(t, test::seed_flow(r));
  CapsuleCoupling cc(ns);
  fluid::Adaptation<3> adaptation(ns, {.min_level = 0});
  adaptation.set_bodies(&cc);
  cc.add_capsule(membrane::MembraneModel(membrane::make_icosphere({.level = 3, .radius = 0.5}), {.gs = 20}),
                 membrane::make_icosphere({.level = 3, .radius = 0.5}).nodes);
  (void)adaptation.refine_initial();
  const double h = 2.0 / 16;
  std::int64_t heavy = 0;
  for (const Index c : t.leaves()) {
    const int l = t.level_of(c);
    const std::int64_t w = cc.leaf_weight(l, tree::morton_encode<3>(t.coords(c)), 7);
    const tree::Box<3> b = t.box(c);
    const bool in_band = l == 4 && cc.required_level(b) == 4;
    EXPECT_EQ(w, in_band ? 7 : 1) << "leaf of level " << l;
    const Eigen::Vector3d centre{(b.lo[0] + b.hi[0]) / 2, (b.lo[1] + b.hi[1]) / 2, (b.lo[2] + b.hi[2]) / 2};
    if (std::abs(centre.norm() - 0.5) < 2 * h) {
      EXPECT_EQ(w, 7) << "a leaf on the membrane";
    }
    heavy += w == 7;
  }
  EXPECT_GT(heavy, 1000);
}

}  // namespace
}  // namespace capsflow::ibm
