// Flexible GMRES (gmres.hpp) on small dense systems against Eigen's LU: the solution, the
// residual it reports, an exact preconditioner converging in one product, and a system it
// cannot finish in the products it is given.
#include "common/gmres.hpp"

#include <gtest/gtest.h>
#include <Eigen/LU>

#include <random>

namespace capsflow {
namespace {

// I + a nonsymmetric random part: eigenvalues in a disc of radius `spread` around 1.
Eigen::MatrixXd random_system(int n, double spread, std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::MatrixXd a(n, n);
  for (Eigen::Index i = 0; i < a.size(); ++i) a.data()[i] = normal(rng);
  return Eigen::MatrixXd::Identity(n, n) + (spread / std::sqrt(double(n))) * a;
}

const auto euclidean = [](const Eigen::VectorXd& a, const Eigen::VectorXd& b) { return a.dot(b); };
const auto identity = [](const Eigen::VectorXd& v) { return v; };

TEST(Gmres, SolvesWithTheResidualItReports) {
  std::mt19937 rng(7);
  const int n = 60;
  const Eigen::MatrixXd a = random_system(n, 0.6, rng);
  const Eigen::VectorXd b = Eigen::VectorXd::Random(n);
  Eigen::VectorXd x;
  const auto r = fgmres([&](const Eigen::VectorXd& v) { return Eigen::VectorXd(a * v); }, identity, euclidean, b, x,
                        1e-12, n);
  ASSERT_TRUE(r.converged);
  EXPECT_LT(r.iterations, n);
  const double true_residual = (b - a * x).norm() / b.norm();
  EXPECT_LE(true_residual, 1e-11);
  EXPECT_NEAR(r.residual, true_residual, 1e-11);
  EXPECT_LT((x - a.partialPivLu().solve(b)).norm(), 1e-9 * x.norm());
}

TEST(Gmres, ExactPreconditionerNeedsOneProduct) {
  std::mt19937 rng(8);
  const Eigen::MatrixXd a = random_system(40, 2.0, rng);
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(a);
  const Eigen::VectorXd b = Eigen::VectorXd::Random(40);
  Eigen::VectorXd x;
  const auto r = fgmres([&](const Eigen::VectorXd& v) { return Eigen::VectorXd(a * v); },
                        [&](const Eigen::VectorXd& v) { return Eigen::VectorXd(lu.solve(v)); }, euclidean, b, x, 1e-10,
                        10);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_LT((a * x - b).norm(), 1e-10 * b.norm());
}

TEST(Gmres, ReportsWhatItDidNotFinish) {
  std::mt19937 rng(9);
  const Eigen::MatrixXd a = random_system(80, 0.9, rng);
  const Eigen::VectorXd b = Eigen::VectorXd::Random(80);
  Eigen::VectorXd x;
  const auto r = fgmres([&](const Eigen::VectorXd& v) { return Eigen::VectorXd(a * v); }, identity, euclidean, b, x,
                        1e-12, 5);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.iterations, 5);
  EXPECT_GT(r.residual, 1e-12);
  EXPECT_NEAR(r.residual, (b - a * x).norm() / b.norm(), 1e-12);  // the best x of the five products
}

TEST(Gmres, ZeroRightHandSideIsSolvedByZero) {
  Eigen::VectorXd x = Eigen::VectorXd::Ones(4);
  const auto r = fgmres([](const Eigen::VectorXd& v) { return v; }, identity, euclidean, Eigen::VectorXd::Zero(4), x,
                        1e-6, 3);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(x.norm(), 0.0);
}

}  // namespace
}  // namespace capsflow
