// Nodal forces: they are the energy gradient, they respect rigid motions (zero total force
// and torque, objectivity), the assembly is race-free, and bad configurations are named.
#include "membrane/errors.hpp"
#include "membrane/forces.hpp"
#include "membrane/mesh.hpp"
#include "membrane/shapes.hpp"
#include "configurations.hpp"
#include "test_support.hpp"

#include <gmock/gmock.h>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>

namespace capsflow::membrane {
namespace {

using ::testing::HasSubstr;
using test::Case;
using test::describe;
using test::max_norm;
using test::random_configuration;
using test::setups;

TEST(membrane_forces, AreTheNegativeEnergyGradient) {
  std::mt19937 rng(2024);
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level, .radius = 1.0}), s.law,
                              {.quadrature_degree = s.quadrature_degree});
    for (int sample = 0; sample < 1; ++sample) {
      Eigen::Matrix3Xd x = random_configuration(model.mesh(), rng);
      Eigen::Matrix3Xd f;
      const double e = model.compute_forces(x, f);
      EXPECT_NEAR(e, model.energy(x), 1e-13 * e);
      Eigen::Matrix3Xd fd(3, x.cols());
      const double h = 1e-6;
      for (Eigen::Index i = 0; i < x.size(); ++i) {
        const double saved = x.data()[i];
        x.data()[i] = saved + h;
        const double ep = model.energy(x);
        x.data()[i] = saved - h;
        const double em = model.energy(x);
        x.data()[i] = saved;
        fd.data()[i] = -(ep - em) / (2 * h);
      }
      const double relative = max_norm(fd - f) / max_norm(f);
      EXPECT_LT(relative, 1e-6) << describe(s);
      if (sample == 0) std::printf("[ gradient  ] %-50s max|F_fd - F|/max|F| = %.2e\n", describe(s).c_str(), relative);
    }
  }
}

TEST(membrane_forces, RigidMotionsLeaveEnergyAndRotateForces) {
  std::mt19937 rng(99);
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level}), s.law,
                              {.quadrature_degree = s.quadrature_degree});
    const Eigen::Matrix3Xd x = random_configuration(model.mesh(), rng);
    const Eigen::Matrix3d r = test::random_rotation(rng);
    const Eigen::Vector3d t(3.0, -1.5, 0.25);
    const Eigen::Matrix3Xd moved = (r * x).colwise() + t;
    Eigen::Matrix3Xd f, f_moved;
    const double e = model.compute_forces(x, f);
    const double e_moved = model.compute_forces(moved, f_moved);
    EXPECT_NEAR(e_moved, e, 1e-13 * e) << describe(s);
    EXPECT_LT(max_norm(f_moved - r * f), 1e-12 * max_norm(f)) << describe(s);
  }
}

TEST(membrane_forces, TotalForceAndTorqueVanish) {
  std::mt19937 rng(5);
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level}), s.law,
                              {.quadrature_degree = s.quadrature_degree});
    const Eigen::Matrix3Xd x = (random_configuration(model.mesh(), rng).colwise() + Eigen::Vector3d(4.0, 0.5, -0.5));
    Eigen::Matrix3Xd f;
    (void)model.compute_forces(x, f);
    const double force_scale = f.colwise().norm().sum();
    double torque_scale = 0.0;
    Eigen::Vector3d torque = Eigen::Vector3d::Zero();
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      torque += x.col(i).cross(f.col(i));
      torque_scale += x.col(i).norm() * f.col(i).norm();
    }
    EXPECT_LT(f.rowwise().sum().norm(), 1e-14 * force_scale) << describe(s);
    EXPECT_LT(torque.norm(), 1e-14 * torque_scale) << describe(s);
  }
}

TEST(membrane_forces, ReferenceConfigurationIsStressFree) {
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level, .radius = 0.85}), s.law,
                              {.quadrature_degree = s.quadrature_degree});
    Eigen::Matrix3Xd f;
    const double e = model.compute_forces(model.mesh().nodes, f);
    EXPECT_LT(std::abs(e), 1e-14);
    EXPECT_LT(max_norm(f), 1e-14) << describe(s);
  }
}

TEST(membrane_forces, InflatedSphereElementTensionsAreTheLawsTension) {
  const double lambda = 1.3;
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level}), s.law);
    const double exact = std::visit([&](const auto& law) { return tensions_from_stretches(law, lambda, lambda).t1; }, model.law());
    for (const PrincipalTensions& t : model.element_tensions(inflate(model.mesh().nodes, lambda, Eigen::Vector3d::Zero()))) {
      ASSERT_NEAR(t.lambda1, lambda, 1e-12);
      ASSERT_NEAR(t.lambda2, lambda, 1e-12);
      ASSERT_NEAR(t.t1, exact, 1e-12 * exact);
      ASSERT_NEAR(t.t2, exact, 1e-12 * exact);
    }
  }
}

// The seed's Hammer 3-point rule under-integrates a curved P2 element; on the closed sphere
// the assembled stiffness K = -dF/dx (central differences of F) must still have exactly the
// six rigid-body zero modes and no spurious (hourglass) mode, and be positive otherwise.
TEST(membrane_forces, StiffnessHasOnlyTheRigidZeroModes) {
  for (const Order order : {Order::p1, Order::p2}) {
    MembraneModel model(make_icosphere({.order = order, .level = order == Order::p1 ? 2 : 3}),
                              {.kind = LawKind::skalak, .gs = 1.0, .c = 1.0});
    Eigen::Matrix3Xd x = model.mesh().nodes, fp, fm;
    const Eigen::Index n = x.size();
    Eigen::MatrixXd k(n, n);
    const double h = 1e-6;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double saved = x.data()[i];
      x.data()[i] = saved + h;
      (void)model.compute_forces(x, fp);
      x.data()[i] = saved - h;
      (void)model.compute_forces(x, fm);
      x.data()[i] = saved;
      const Eigen::Matrix3Xd df = (fm - fp) / (2 * h);
      k.col(i) = Eigen::Map<const Eigen::VectorXd>(df.data(), n);
    }
    EXPECT_LT((k - k.transpose()).cwiseAbs().maxCoeff(), 1e-6 * k.cwiseAbs().maxCoeff());
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (k + k.transpose()), Eigen::EigenvaluesOnly);
    const Eigen::VectorXd& ev = eig.eigenvalues();  // ascending
    const double largest = ev.cwiseAbs().maxCoeff();
    int zero = 0;
    for (Eigen::Index i = 0; i < n; ++i) zero += std::abs(ev[i]) < 1e-8 * largest ? 1 : 0;
    EXPECT_EQ(zero, 6) << (order == Order::p1 ? "P1" : "P2");
    EXPECT_GT(ev[6], 1e-4 * largest) << (order == Order::p1 ? "P1" : "P2");
    std::printf("[ stiffness ] %s dofs %ld: %d zero modes, smallest non-zero / largest = %.2e\n",
                order == Order::p1 ? "P1" : "P2", static_cast<long>(n), zero, ev[6] / largest);
  }
}

// Each node sums its element contributions in element order whatever the thread count, and
// the energy its elements' in element order: forces and energy are bitwise independent of it
// (the energy was an OpenMP reduction: the seed case's E_membrane differed in its last digits
// between 1 rank x 2 threads and 2 ranks x 1 thread).
TEST(membrane_forces, AssemblyIsBitwiseIndependentOfThreadCount) {
  std::mt19937 rng(8);
  const int saved = omp_get_max_threads();
  for (const Order order : {Order::p1, Order::p2}) {
    MembraneModel model(make_icosphere({.order = order, .level = 4}), {});
    const Eigen::Matrix3Xd x = random_configuration(model.mesh(), rng);
    Eigen::Matrix3Xd f1, f2, f3;
    omp_set_num_threads(1);
    const double e1 = model.compute_forces(x, f1), energy1 = model.energy(x);
    omp_set_num_threads(2);
    const double e2 = model.compute_forces(x, f2), energy2 = model.energy(x);
    omp_set_num_threads(3);
    const double e3 = model.compute_forces(x, f3), energy3 = model.energy(x);
    EXPECT_TRUE(f1 == f2);
    EXPECT_TRUE(f1 == f3);
    EXPECT_EQ(e1, e2);
    EXPECT_EQ(e1, e3);
    EXPECT_EQ(energy1, e1);
    EXPECT_EQ(energy2, e1);
    EXPECT_EQ(energy3, e1);
  }
  omp_set_num_threads(saved);
}

std::string force_message(MembraneModel& model, const Eigen::Matrix3Xd& x, std::int64_t* element = nullptr) {
  try {
    Eigen::Matrix3Xd f;
    (void)model.compute_forces(x, f);
  } catch (const ElementError& e) {
    if (element != nullptr) *element = e.element();
    return e.what();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no exception";
}

TEST(membrane_forces, CollapsedOrFoldedElementsAreNamed) {
  // P1: collapse the edge (v0, v1) of element 30; the lowest-numbered element holding both
  // nodes is reported.
  {
    MembraneModel model(make_icosphere({.order = Order::p1, .level = 2}), {});
    Eigen::Matrix3Xd x = model.mesh().nodes;
    const auto v = model.mesh().element(30);
    x.col(v[0]) = x.col(v[1]);
    std::int64_t expected = -1;
    for (std::int64_t e = 0; e < model.mesh().element_count() && expected < 0; ++e) {
      const auto w = model.mesh().element(e);
      if (std::count(w.begin(), w.end(), v[0]) && std::count(w.begin(), w.end(), v[1])) expected = e;
    }
    std::int64_t element = -1;
    EXPECT_THAT(force_message(model, x, &element),
                HasSubstr("element " + std::to_string(expected) + " is degenerate in the current configuration: det C = J^2 = 0"));
    EXPECT_EQ(element, expected);
    EXPECT_THROW((void)model.energy(x), ElementError);
  }
  // P2: the mid-edge node of edge (1,2) of element 12 pushed across vertex 0 folds the element.
  {
    MembraneModel model(make_icosphere({.order = Order::p2, .level = 3}), {});
    Eigen::Matrix3Xd x = model.mesh().nodes;
    const auto v = model.mesh().element(12);
    x.col(v[4]) = x.col(v[0]) + 1.5 * (x.col(v[0]) - 0.5 * (x.col(v[1]) + x.col(v[2])));
    const std::string message = force_message(model, x);
    EXPECT_THAT(message, HasSubstr("is inverted (folded) in the current configuration"));
    std::printf("[ bad input ] %s\n", message.c_str());
  }
  // A NaN position (a blown-up run) is reported, not propagated.
  {
    MembraneModel model(make_icosphere({.order = Order::p1, .level = 1}), {});
    Eigen::Matrix3Xd x = model.mesh().nodes;
    x(1, 7) = std::nan("");
    EXPECT_THAT(force_message(model, x), HasSubstr("det C = J^2 = nan"));
  }
  // A configuration of the wrong size.
  {
    MembraneModel model(make_icosphere({.order = Order::p1, .level = 1}), {});
    EXPECT_THAT(force_message(model, Eigen::Matrix3Xd::Zero(3, 5)), HasSubstr("configuration has 5 nodes, the mesh 42"));
  }
}

TEST(membrane_forces, BadOptionsAndShapesNameTheValue) {
  const Mesh mesh = make_icosphere({.level = 1});
  try {
    MembraneModel model(mesh, {}, {.quadrature_degree = -2});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("quadrature degree -2"));
  }
  try {
    (void)inflate(mesh.nodes, -1.5, Eigen::Vector3d::Zero());
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("lambda = -1.5"));
  }
  try {
    (void)map_linear(mesh.nodes, Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal(), Eigen::Vector3d::Zero());
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("det A = -1"));
  }
}

}  // namespace
}  // namespace capsflow::membrane
