// The coupling's energy transfer (issue 32): the power of the spread force against the face
// velocity equals the node forces' power against the node velocities when spreading and
// interpolation are adjoint; and the early response of an impulsively started relaxation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "coupling_support.hpp"
#include "fluid/energy.hpp"
#include "ibm/interpolate.hpp"
#include "ibm/spread.hpp"

namespace capsflow::ibm {
namespace {

using test::SeedRun;

double spread_power(const test::SeedSetup& s) {
  return fluid::face_power<3>(*s.tree, s.ns->face_force(), s.ns->face_velocity());
}

// sum_nodes F . V = sum_faces f uf dx^3 to round-off with the same kernel on both stages
// (spreading is interpolation's adjoint), whatever the node scheme; the seed's cosine/hat
// pair is not adjoint and the two differ by several per cent.
TEST(Energy, SpreadPowerEqualsNodePowerWhenKernelsMatch) {
  for (const NodeScheme scheme : {NodeScheme::euler, NodeScheme::midpoint})
    for (const KernelKind interpolate : {KernelKind::cosine, KernelKind::peskin4, KernelKind::hat}) {
      SeedRun r{.max_level = 4};
      r.kernels.spread = interpolate == KernelKind::peskin4 ? KernelKind::peskin4 : KernelKind::cosine;
      r.kernels.interpolate = interpolate;
      auto s = test::seed_setup(r);
      s.coupling->set_node_scheme(scheme);
      double worst = 0.0;
      for (int k = 0; k < 5; ++k) {
        (void)s.coupling->step();  // the faces before the adaptation resets them
        const double nodes = s.coupling->node_power(0), faces = spread_power(s);
        (void)s.adaptation->after_step(s.coupling->steps());
        worst = std::max(worst, std::abs(nodes - faces) / std::abs(nodes));
      }
      std::printf("%s nodes, %s interpolation: max |P_nodes - P_spread| / |P_nodes| = %.2e\n",
                  scheme == NodeScheme::euler ? "Euler" : "midpoint", std::string(name_of(interpolate)).c_str(), worst);
      if (interpolate == KernelKind::hat) {
        EXPECT_GT(worst, 1e-2);
      } else {
        EXPECT_LT(worst, 1e-12);
      }
    }
}

}  // namespace
}  // namespace capsflow::ibm

// Early times of an impulsively started relaxation (the seed's ellipsoid, Re = 1000 so that
// t = 0.01 is far below the viscous time of the kernel's width, (4 dx)^2 Re = 16-62; 10 steps
// of 1e-3 on a fixed grid). The fluid starts from rest under the spread force f: with
// inertia alone the face velocity after n steps is the projected force times t over the
// density, uf = n dt P f / rho, and the nodes move at V^n = n V^1 (V^1 = dt J P f / rho, the
// first step's, the same in both schemes). The carried faces (fluid.carry_faces) follow
// that. The default scheme rebuilds the faces every step from the cell velocity, whose
// update is the cell mean C of the face acceleration, so from the second step on the faces
// see the force through the mean A C of neighbouring faces:
//   uf^n = dt/rho (q + (n - 1) P A C q) + (terms with P A C applied to gradients),  q = P f,
// and along V^1, V^n / (n V^1) = (1 + (n - 1) a) / n with a = (J P A C q) . (J q) / |J q|^2,
// computed here from the operators (a projection on a copy of the grid). Measured at
// dx = 1/8 and 1/16: carried 0.9995 and 0.9985 (limit 1), default 0.9568 and 0.9522 (limits
// 0.9607 and 0.9575): in the inertial phase the default scheme's membrane moves 4-5% slower
// than the projected force allows, the carried faces within the viscous correction.
namespace capsflow::ibm {
namespace {

using test::SeedRun;

struct EarlyResponse {
  double ratio;      // (V^n . V^1) / (n |V^1|^2), the coupled run
  double predicted;  // (1 + (n - 1) a) / n, the default scheme's limit
};

void early_response(int max_level, bool carry, int steps, EarlyResponse& out) {
  SeedRun r{.max_level = max_level, .dt = 1e-3, .Re = 1000.0, .tolerance = 1e-10, .carry_faces = carry};
  r.kernels.interpolate = KernelKind::cosine;
  r.adapt.enabled = false;
  auto s = test::seed_setup(r);
  const Eigen::Matrix3Xd x0 = s.coupling->capsule(0).x;
  (void)s.coupling->step();
  const Eigen::Matrix3Xd v1 = s.coupling->capsule(0).velocity;
  const fluid::FaceField<3> q = s.ns->face_velocity();  // dt P f / rho
  for (int k = 1; k < steps; ++k) (void)s.coupling->step();
  const Eigen::Matrix3Xd& vn = s.coupling->capsule(0).velocity;

  // P A C q by a projection on a copy of the (uniform) tree: a second solver at rest whose
  // face force is A C q / dt makes its first step's face velocity P A C q.
  const tree::Tree<3>& t = *s.tree;
  tree::Tree<3> copy(t.options());
  copy.refine_to([&](const tree::Box<3>&) { return max_level; });
  ASSERT_EQ(copy.num_cells(), t.num_cells());
  for (const Index c : t.leaves()) ASSERT_EQ(copy.center(c), t.center(c));
  std::array<std::vector<double>, 3> cells;
  for (int d = 0; d < 3; ++d) cells[d].assign(static_cast<std::size_t>(t.num_cells()), 0.0);
  for (const Index c : t.leaves()) {
    const Index* row = t.level(t.level_of(c)).face_row(c);
    for (int d = 0; d < 3; ++d) cells[d][c] = 0.5 * (q[d][c] + q[d][row[2 * d + 1]]);
  }
  fluid::NavierStokes<3> projector(copy, test::seed_flow(r));
  projector.set_face_force([&](const tree::Tree<3>& tr, fluid::FaceField<3>& f) {
    ibm::cell_to_face_force<3>(tr, cells, f);
    for (auto& component : f)
      for (double& v : component) v /= r.dt;
  });
  for (auto& component : cells) copy.sync(component, tree::BoundaryConditions<3>::all(tree::BcKind::dirichlet));
  (void)projector.step();
  Eigen::Matrix3Xd vac;
  interpolate_faces(KernelKind::cosine, true, copy, projector.face_velocity(), x0, vac);
  const double a = vac.cwiseProduct(v1).sum() / v1.squaredNorm();
  out = {vn.cwiseProduct(v1).sum() / v1.squaredNorm() / steps, (1.0 + (steps - 1) * a) / steps};
}

TEST(Energy, EarlyResponseIsTheProjectedForceTimesT) {
  for (const int level : {4, 5})
    for (const bool carry : {false, true}) {
      EarlyResponse e{};
      early_response(level, carry, 10, e);
      std::printf("dx = 1/%d, %s faces: V^10 . V^1 / (10 |V^1|^2) = %.4f; limits: carried 1, default %.4f\n",
                  1 << (level - 1), carry ? "carried" : "default", e.ratio, e.predicted);
      if (carry) {
        EXPECT_NEAR(e.ratio, 1.0, 0.005);
      } else {
        EXPECT_NEAR(e.ratio, e.predicted, 0.01);
        EXPECT_LT(e.predicted, 0.97) << "the A C lag is a few per cent at the kernel's scale";
      }
    }
}

}  // namespace
}  // namespace capsflow::ibm
