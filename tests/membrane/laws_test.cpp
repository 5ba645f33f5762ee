// Constitutive laws: tensions against the reference tables and formulas, through the law
// types and through the finite-element kinematics of flat patches; parameter validation.
#include "membrane/errors.hpp"
#include "membrane/forces.hpp"
#include "membrane/laws.hpp"
#include "membrane/mesh.hpp"
#include "test_support.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace capsflow::membrane {
namespace {

using ::testing::HasSubstr;

// README formulas (tensions per deformed length).
double skalak_t1(double gs, double c, double l1, double l2) {
  return gs * (l1 / l2) * (l1 * l1 - 1.0 + c * l2 * l2 * (l1 * l1 * l2 * l2 - 1.0));
}
double neo_hookean_t1(double gs, double l1, double l2) {
  return gs / (l1 * l2) * (l1 * l1 - 1.0 / (l1 * l1 * l2 * l2));
}

// Exact lateral stretch of the uniaxial state T2 = 0 (csv header).
double uniaxial_lambda2_nh(double l1) { return 1.0 / std::sqrt(l1); }
double uniaxial_lambda2_sk(double l1, double c) { return std::sqrt((1.0 + c * l1 * l1) / (1.0 + c * l1 * l1 * l1 * l1)); }

// The csv prints 10 decimals: agreement to half a unit in the last place, plus round-off.
constexpr double table_precision = 0.5e-10 + 1e-15;

TEST(membrane_laws, UniaxialTensionMatchesTableAndFormulas) {
  const test::ReferenceTable table("membrane_uniaxial_tension.csv");
  const NeoHookean nh{.gs = 1.0};
  const Skalak sk{.gs = 1.0, .c = 1.0};
  ASSERT_GT(table.rows(), 40u);
  for (std::size_t r = 0; r < table.rows(); ++r) {
    const double l1 = table.column("lambda1")[r];
    const double l2_nh = uniaxial_lambda2_nh(l1), l2_sk = uniaxial_lambda2_sk(l1, 1.0);
    EXPECT_NEAR(l2_nh, table.column("lambda2_NH")[r], table_precision);
    EXPECT_NEAR(l2_sk, table.column("lambda2_SK_C1")[r], table_precision);
    const PrincipalTensions tn = tensions_from_stretches(nh, l1, l2_nh);
    const PrincipalTensions ts = tensions_from_stretches(sk, l1, l2_sk);
    const double scale = 1.0 + std::abs(ts.t1);
    EXPECT_NEAR(tn.t1, table.column("T1_NH_over_Gs")[r], table_precision) << "lambda1 " << l1;
    EXPECT_NEAR(ts.t1, table.column("T1_SK_C1_over_Gs")[r], table_precision * scale) << "lambda1 " << l1;
    // Against the closed forms, to round-off; the lateral tension vanishes to round-off.
    EXPECT_NEAR(tn.t1, neo_hookean_t1(1.0, l1, l2_nh), 1e-14 * (1.0 + tn.t1));
    EXPECT_NEAR(ts.t1, skalak_t1(1.0, 1.0, l1, l2_sk), 1e-14 * scale);
    EXPECT_NEAR(tn.t2, 0.0, 1e-14 * (1.0 + tn.t1));
    EXPECT_NEAR(ts.t2, 0.0, 1e-14 * scale);
  }
}

TEST(membrane_laws, IsotropicTensionMatchesTable) {
  const test::ReferenceTable table("membrane_isotropic_inflation.csv");
  const NeoHookean nh{.gs = 1.0};
  for (std::size_t r = 0; r < table.rows(); ++r) {
    const double l = table.column("lambda")[r];
    EXPECT_NEAR(tensions_from_stretches(nh, l, l).t1, table.column("T_NH_over_Gs")[r], table_precision);
    const double t1 = tensions_from_stretches(Skalak{.gs = 1.0, .c = 1.0}, l, l).t1;
    const double t10 = tensions_from_stretches(Skalak{.gs = 1.0, .c = 10.0}, l, l).t1;
    EXPECT_NEAR(t1, table.column("T_SK_C1_over_Gs")[r], table_precision * (1.0 + t1));
    EXPECT_NEAR(t10, table.column("T_SK_C10_over_Gs")[r], table_precision * (1.0 + t10));
  }
}

// The derivatives a law reports are those of its energy (central differences).
template <MembraneLaw Law>
void expect_consistent_derivatives(const Law& law) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> stretch(0.6, 1.8);
  for (int k = 0; k < 50; ++k) {
    const double l1 = stretch(rng), l2 = stretch(rng);
    const double tr = l1 * l1 + l2 * l2, det = l1 * l1 * l2 * l2, h = 1e-6;
    const auto d = law.derivatives(tr, det);
    const double fd_tr = (law.energy(tr + h, det) - law.energy(tr - h, det)) / (2 * h);
    const double fd_det = (law.energy(tr, det + h) - law.energy(tr, det - h)) / (2 * h);
    EXPECT_NEAR(d.w_tr, fd_tr, 1e-8 * (1.0 + std::abs(fd_tr)));
    EXPECT_NEAR(d.w_det, fd_det, 1e-8 * (1.0 + std::abs(fd_det)));
  }
  // The reference state is stress-free and has zero energy.
  EXPECT_EQ(law.energy(2.0, 1.0), 0.0);
  const auto t = tensions_from_stretches(law, 1.0, 1.0);
  EXPECT_EQ(t.t1, 0.0);
  EXPECT_EQ(t.t2, 0.0);
}

TEST(membrane_laws, DerivativesAreThoseOfTheEnergy) {
  expect_consistent_derivatives(Skalak{.gs = 1.7, .c = 1.0});
  expect_consistent_derivatives(Skalak{.gs = 0.3, .c = 10.0});
  expect_consistent_derivatives(NeoHookean{.gs = 2.5});
}

// A flat, irregular patch of P1 or P2 triangles in an arbitrary plane, stretched
// uniaxially by x = R diag(l1, l2, 1) R^T X: every element must report the exact tensions.
Mesh flat_patch(Order order, const Eigen::Matrix3d& rotation) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.15, 0.15);
  const int n = order == Order::p1 ? 5 : 9;  // nodes per side (P2: every other is mid-edge)
  Eigen::Matrix3Xd plane(3, n * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const bool interior = i > 0 && j > 0 && i < n - 1 && j < n - 1;
      plane.col(j * n + i) = Eigen::Vector3d(i + (interior ? jitter(rng) : 0.0), j + (interior ? jitter(rng) : 0.0), 0.0);
    }
  Mesh mesh;
  mesh.order = order;
  mesh.nodes = rotation * plane / (n - 1);
  const int step = order == Order::p1 ? 1 : 2;
  const auto id = [n](int i, int j) { return static_cast<std::int32_t>(j * n + i); };
  for (int j = 0; j + step < n; j += step)
    for (int i = 0; i + step < n; i += step) {
      if (order == Order::p1) {
        mesh.elements.insert(mesh.elements.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        mesh.elements.insert(mesh.elements.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      } else {
        mesh.elements.insert(mesh.elements.end(), {id(i, j), id(i + 2, j), id(i + 2, j + 2), id(i + 1, j),
                                                   id(i + 2, j + 1), id(i + 1, j + 1)});
        mesh.elements.insert(mesh.elements.end(), {id(i, j), id(i + 2, j + 2), id(i, j + 2), id(i + 1, j + 1),
                                                   id(i + 1, j + 2), id(i, j + 1)});
      }
    }
  return mesh;
}

TEST(membrane_laws, FlatPatchUniaxialElementTensionsAreExact) {
  std::mt19937 rng(11);
  const test::ReferenceTable table("membrane_uniaxial_tension.csv");
  for (const Order order : {Order::p1, Order::p2}) {
    const Eigen::Matrix3d rotation = test::random_rotation(rng);
    const Mesh patch = flat_patch(order, rotation);
    MembraneModel nh(patch, {.kind = LawKind::neo_hookean, .gs = 1.0});
    MembraneModel sk(patch, {.kind = LawKind::skalak, .gs = 1.0, .c = 1.0});
    for (std::size_t r = 1; r < table.rows(); r += 4) {
      const double l1 = table.column("lambda1")[r];
      for (const auto& [model, l2, t1_column] :
           {std::tuple{&nh, uniaxial_lambda2_nh(l1), "T1_NH_over_Gs"}, std::tuple{&sk, uniaxial_lambda2_sk(l1, 1.0), "T1_SK_C1_over_Gs"}}) {
        const Eigen::Matrix3d stretch = rotation * Eigen::Vector3d(l1, l2, 1.0).asDiagonal() * rotation.transpose();
        const Eigen::Matrix3Xd x = stretch * patch.nodes;
        const double t1_table = table.column(t1_column)[r];
        for (const PrincipalTensions& t : model->element_tensions(x)) {
          ASSERT_NEAR(t.lambda1, l1, 1e-14 * l1);
          ASSERT_NEAR(t.lambda2, l2, 1e-14);
          ASSERT_NEAR(t.t1, t1_table, table_precision * (1.0 + t1_table));
          ASSERT_NEAR(t.t2, 0.0, 1e-13 * (1.0 + t1_table));
        }
      }
    }
  }
}

std::string law_message(const LawParameters& p) {
  try {
    (void)make_law(p);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no exception";
}

TEST(membrane_laws, BadParametersNameTheValue) {
  EXPECT_THAT(law_message({.kind = LawKind::skalak, .gs = 0.0}), HasSubstr("Skalak law: shear modulus Gs = 0 must be positive"));
  EXPECT_THAT(law_message({.kind = LawKind::neo_hookean, .gs = -2.5}), HasSubstr("neo-Hookean law: shear modulus Gs = -2.5"));
  EXPECT_THAT(law_message({.kind = LawKind::neo_hookean, .gs = std::nan("")}), HasSubstr("Gs = nan"));
  EXPECT_THAT(law_message({.kind = LawKind::skalak, .gs = 1.0, .c = -0.75}), HasSubstr("Skalak law: C = -0.75 must be finite and > -1/2"));
  EXPECT_THAT(law_message({.kind = LawKind::skalak, .gs = 1.0, .c = 1.0}), HasSubstr("no exception"));
  // The model validates at construction, before any precomputation.
  try {
    MembraneModel model(make_icosphere({.level = 1}), {.kind = LawKind::skalak, .gs = -1.0});
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("Gs = -1"));
  }
}

}  // namespace
}  // namespace capsflow::membrane
