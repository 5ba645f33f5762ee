// The tangent stiffness K = d2E/dX2: it is the Jacobian of -F, symmetric, it respects rigid
// motions (translations are zero modes, an infinitesimal rotation turns the forces), its
// positive variant is positive, its assembly is race-free, and bad configurations are named
// as for the forces.
#include "configurations.hpp"
#include "membrane/errors.hpp"
#include "membrane/forces.hpp"
#include "membrane/mesh.hpp"
#include "membrane/shapes.hpp"

#include <gmock/gmock.h>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>

namespace capsflow::membrane {
namespace {

using test::Case;
using test::describe;
using test::max_norm;
using test::random_configuration;
using test::setups;

Eigen::Matrix3Xd times(const Eigen::SparseMatrix<double>& k, const Eigen::Matrix3Xd& v) {
  Eigen::Matrix3Xd out(3, v.cols());
  Eigen::Map<Eigen::VectorXd>(out.data(), out.size()) = k * Eigen::Map<const Eigen::VectorXd>(v.data(), v.size());
  return out;
}

Eigen::Matrix3Xd random_direction(Eigen::Index nodes, std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Matrix3Xd v(3, nodes);
  for (Eigen::Index i = 0; i < v.size(); ++i) v.data()[i] = normal(rng);
  return v;
}

// K v against central differences of the forces along random directions: their error is
// the difference's own, c h^2 (third derivatives of E), so it falls 100-fold from h = 1e-4 to
// 1e-5 when K is the exact Jacobian and stalls at K's error otherwise.
TEST(membrane_stiffness, IsTheJacobianOfMinusTheForces) {
  std::mt19937 rng(30);
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level, .radius = 1.0}), s.law,
                        {.quadrature_degree = s.quadrature_degree});
    const Eigen::Matrix3Xd x = random_configuration(model.mesh(), rng);
    const Eigen::SparseMatrix<double> k = model.stiffness(x);
    const Eigen::Matrix3Xd v = random_direction(x.cols(), rng);
    const Eigen::Matrix3Xd kv = times(k, v);
    const auto error = [&](double h) {
      Eigen::Matrix3Xd fp, fm;
      (void)model.compute_forces(x + h * v, fp);
      (void)model.compute_forces(x - h * v, fm);
      return max_norm((fm - fp) / (2 * h) - kv) / max_norm(kv);
    };
    const double coarse = error(1e-4), fine = error(1e-5);
    EXPECT_LT(fine, 3e-6) << describe(s);
    EXPECT_NEAR(coarse / fine, 100.0, 5.0) << describe(s);
    std::printf("[ jacobian  ] %-50s max|K v - (F(x-hv) - F(x+hv))/2h| / max|K v| = %.2e (h = 1e-5), %.2e (h = 1e-4)\n",
                describe(s).c_str(), fine, coarse);
  }
}

TEST(membrane_stiffness, IsSymmetric) {
  std::mt19937 rng(31);
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level}), s.law,
                        {.quadrature_degree = s.quadrature_degree});
    const Eigen::SparseMatrix<double> k = model.stiffness(random_configuration(model.mesh(), rng));
    const Eigen::SparseMatrix<double> asymmetry = k - Eigen::SparseMatrix<double>(k.transpose());
    EXPECT_LE(asymmetry.coeffs().cwiseAbs().maxCoeff(), 1e-14 * k.coeffs().cwiseAbs().maxCoeff()) << describe(s);
  }
}

// E(R X + t) = E(X) for all rotations R and translations t, so K t = 0 and, differentiating
// F(R X) = R F(X) along R = exp(theta [w]x), K (w x X) = -(w x F): at a stressed
// configuration a rotation is not a zero mode; its image is the rotated force.
TEST(membrane_stiffness, TranslationsAreZeroModesAndRotationsTurnTheForces) {
  std::mt19937 rng(32);
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level}), s.law,
                        {.quadrature_degree = s.quadrature_degree});
    const Eigen::Matrix3Xd x = (random_configuration(model.mesh(), rng).colwise() + Eigen::Vector3d(2.0, -1.0, 0.5));
    Eigen::Matrix3Xd f;
    (void)model.compute_forces(x, f);
    const Eigen::SparseMatrix<double> k = model.stiffness(x);
    const double scale = k.coeffs().cwiseAbs().maxCoeff() * x.colwise().norm().maxCoeff();
    const Eigen::Vector3d t(0.3, -1.1, 0.7), w(-0.4, 0.9, 0.2);
    const Eigen::Matrix3Xd translation = t.replicate(1, x.cols());
    EXPECT_LT(max_norm(times(k, translation)), 1e-13 * scale) << describe(s);
    Eigen::Matrix3Xd rotation(3, x.cols()), turned(3, x.cols());
    for (Eigen::Index i = 0; i < x.cols(); ++i) {
      rotation.col(i) = w.cross(Eigen::Vector3d(x.col(i)));
      turned.col(i) = -w.cross(Eigen::Vector3d(f.col(i)));
    }
    EXPECT_LT(max_norm(times(k, rotation) - turned), 1e-12 * max_norm(turned)) << describe(s);
  }
}

// At the stress-free reference only the material part remains: K is positive semi-definite
// there (v^T K v = sum of w W'' (dI)^2 terms >= 0 for laws convex in the invariants).
TEST(membrane_stiffness, IsPositiveAtTheReference) {
  std::mt19937 rng(33);
  for (const Case& s : setups()) {
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level}), s.law,
                        {.quadrature_degree = s.quadrature_degree});
    const Eigen::SparseMatrix<double> k = model.stiffness(model.mesh().nodes);
    for (int sample = 0; sample < 5; ++sample) {
      const Eigen::Matrix3Xd v = random_direction(model.mesh().node_count(), rng);
      const Eigen::Map<const Eigen::VectorXd> flat(v.data(), v.size());
      EXPECT_GT(flat.dot(k * flat), 0.0) << describe(s);
    }
  }
}

// The seed ellipsoid is compressed across its long axis: there the exact K has negative
// eigenvalues (wrinkling modes), which an implicit step would amplify. The positive variant
// has none, and under tension everywhere (an inflated sphere) it is the exact K, for laws
// whose W_det < 0 there: with W_det > 0 (Skalak once C (det C - 1) > 1) a shear of the
// metric at fixed tr C lowers W and each point's Hessian is indefinite.
TEST(membrane_stiffness, PositiveVariantHasNoNegativeEigenvalue) {
  for (const Order order : {Order::p1, Order::p2}) {
    MembraneModel model(make_icosphere({.order = order, .level = order == Order::p1 ? 2 : 3, .radius = 0.85}),
                        {.kind = LawKind::skalak, .gs = 20.0, .c = 1.0});
    const Eigen::Matrix3Xd x = seed_ellipsoid(model.mesh().nodes, Eigen::Vector3d::Zero());
    const auto extremes = [](const Eigen::SparseMatrix<double>& k) {
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Eigen::MatrixXd(k), Eigen::EigenvaluesOnly);
      return std::pair{eig.eigenvalues().minCoeff(), eig.eigenvalues().maxCoeff()};
    };
    const auto [exact_min, exact_max] = extremes(model.stiffness(x));
    const auto [positive_min, positive_max] = extremes(model.stiffness(x, StiffnessPart::positive));
    EXPECT_LT(exact_min, -0.01 * exact_max);
    EXPECT_GT(positive_min, -1e-12 * positive_max);
    std::printf("[ positive  ] %s seed ellipsoid: smallest / largest eigenvalue %.3f exact, %.1e positive\n",
                order == Order::p1 ? "P1" : "P2", exact_min / exact_max, positive_min / positive_max);
  }
}

TEST(membrane_stiffness, PositiveVariantIsTheHessianUnderTension) {
  for (const Case& s : setups()) {
    if (s.law.kind == LawKind::skalak && s.law.c * (std::pow(1.1, 4) - 1.0) > 1.0) continue;
    MembraneModel model(make_icosphere({.order = s.order, .level = s.level}), s.law,
                        {.quadrature_degree = s.quadrature_degree});
    const Eigen::Matrix3Xd x = 1.1 * model.mesh().nodes;
    const Eigen::SparseMatrix<double> exact = model.stiffness(x);
    const Eigen::SparseMatrix<double> positive = model.stiffness(x, StiffnessPart::positive);
    const Eigen::SparseMatrix<double> difference = exact - positive;
    EXPECT_LE(difference.coeffs().cwiseAbs().maxCoeff(), 1e-12 * exact.coeffs().cwiseAbs().maxCoeff()) << describe(s);
  }
}

TEST(membrane_stiffness, AssemblyIsBitwiseIndependentOfThreadCount) {
  std::mt19937 rng(34);
  const int saved = omp_get_max_threads();
  for (const Order order : {Order::p1, Order::p2}) {
    MembraneModel model(make_icosphere({.order = order, .level = 3}), {});
    const Eigen::Matrix3Xd x = random_configuration(model.mesh(), rng);
    for (const StiffnessPart part : {StiffnessPart::exact, StiffnessPart::positive}) {
      omp_set_num_threads(1);
      const Eigen::SparseMatrix<double> one = model.stiffness(x, part);
      omp_set_num_threads(3);
      const Eigen::SparseMatrix<double> three = model.stiffness(x, part);
      omp_set_num_threads(saved);
      ASSERT_EQ(one.nonZeros(), three.nonZeros());
      EXPECT_EQ(0, std::memcmp(one.valuePtr(), three.valuePtr(), sizeof(double) * static_cast<std::size_t>(one.nonZeros())));
    }
  }
}

TEST(membrane_stiffness, CollapsedElementsAreNamed) {
  MembraneModel model(make_icosphere({.order = Order::p1, .level = 1}), {});
  Eigen::Matrix3Xd x = model.mesh().nodes;
  const auto v = model.mesh().element(3);
  x.col(v[0]) = x.col(v[1]);
  try {
    (void)model.stiffness(x);
    ADD_FAILURE() << "a collapsed element was not reported";
  } catch (const ElementError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("is degenerate in the current configuration"));
  }
}

}  // namespace
}  // namespace capsflow::membrane
