// Solids as signed distances: the primitives' distances against closed forms and their
// defining properties (points built on the surface give 0; a point minus phi times the
// gradient lands on the surface at distance |phi|; |grad phi| = 1), every solid 1-Lipschitz,
// set operations classify points as the set logic does, and bad parameters are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include <Eigen/Geometry>

#include "geometry/solid.hpp"

namespace capsflow::geometry {
namespace {

using Eigen::Vector3d;

Vector3d random_point(std::mt19937_64& rng, double half) {
  std::uniform_real_distribution<double> u(-half, half);
  return {u(rng), u(rng), u(rng)};
}

Vector3d gradient(const Solid& s, const Vector3d& x, double h = 1e-6) {
  Vector3d g;
  for (int d = 0; d < 3; ++d) {
    Vector3d a = x, b = x;
    a[d] += h;
    b[d] -= h;
    g[d] = (s.signed_distance(a) - s.signed_distance(b)) / (2 * h);
  }
  return g;
}

// Away from the medial axis (where the gradient jumps) an exact signed distance has a unit
// gradient, and x - phi grad phi is the closest wall point: phi there is 0.
void check_exact(const Solid& s, std::mt19937_64& rng, int samples) {
  int checked = 0;
  for (int i = 0; i < samples; ++i) {
    const Vector3d x = random_point(rng, 3.0);
    const double phi = s.signed_distance(x);
    const Vector3d g = gradient(s, x);
    // Skip points within a finite-difference step of a kink (medial axis, edges).
    if (std::abs(g.norm() - 1.0) > 1e-6) continue;
    ++checked;
    const Vector3d on_wall = x - phi * g;
    EXPECT_NEAR(s.signed_distance(on_wall), 0.0, 1e-8) << "x = " << x.transpose();
  }
  EXPECT_GT(checked, samples * 8 / 10) << "most random points lie off the medial axis";
}

void check_lipschitz(const Solid& s, std::mt19937_64& rng) {
  for (int i = 0; i < 2000; ++i) {
    const Vector3d x = random_point(rng, 3.0), y = x + random_point(rng, 0.5);
    EXPECT_LE(std::abs(s.signed_distance(x) - s.signed_distance(y)), (x - y).norm() * (1 + 1e-12));
  }
}

TEST(Solid, SphereIsItsClosedForm) {
  const SolidPtr s = sphere({0.5, -0.25, 1.0}, 0.75);
  EXPECT_DOUBLE_EQ(s->signed_distance({0.5, -0.25, 1.0}), -0.75);
  EXPECT_DOUBLE_EQ(s->signed_distance({0.5, -0.25, 3.0}), 1.25);
  EXPECT_NEAR(s->signed_distance({0.5 + 0.75, -0.25, 1.0}), 0.0, 1e-15);
  std::mt19937_64 rng(1);
  check_exact(*s, rng, 500);
  check_lipschitz(*s, rng);
}

TEST(Solid, BoxDistancesToFacesEdgesAndCorners) {
  const SolidPtr b = box({-1, -0.5, 0}, {1, 0.5, 2});
  EXPECT_DOUBLE_EQ(b->signed_distance({0, 0, 1}), -0.5);         // nearest faces y = +-0.5
  EXPECT_DOUBLE_EQ(b->signed_distance({3, 0, 1}), 2.0);          // beyond a face
  EXPECT_DOUBLE_EQ(b->signed_distance({2, 1.5, 1}), std::sqrt(2.0));   // beyond an edge
  EXPECT_DOUBLE_EQ(b->signed_distance({2, 1.5, 3}), std::sqrt(3.0));   // beyond a corner
  EXPECT_DOUBLE_EQ(b->signed_distance({1, 0.25, 1}), 0.0);       // on a face
  std::mt19937_64 rng(2);
  check_exact(*b, rng, 500);
  check_lipschitz(*b, rng);
}

TEST(Solid, CylindersInfiniteFlatAndRounded) {
  const Vector3d axis = Vector3d(1, 1, 0).normalized();
  const SolidPtr infinite = cylinder({.centre = {0, 0, 0}, .axis = {2, 2, 0}, .radius = 0.5});
  const Vector3d across = Vector3d(1, -1, 0).normalized();
  EXPECT_NEAR(infinite->signed_distance(10 * axis + 1.5 * across), 1.0, 1e-14);
  EXPECT_NEAR(infinite->signed_distance(-7 * axis), -0.5, 1e-14);

  const SolidPtr flat = cylinder({.centre = {0, 0, 0}, .axis = {0, 0, 1}, .radius = 1.0, .half_length = 2.0});
  EXPECT_DOUBLE_EQ(flat->signed_distance({0, 0, 0}), -1.0);
  EXPECT_DOUBLE_EQ(flat->signed_distance({0, 0, 3}), 1.0);                 // beyond an end
  EXPECT_DOUBLE_EQ(flat->signed_distance({0, 3, 0}), 2.0);                 // beside it
  EXPECT_DOUBLE_EQ(flat->signed_distance({0, 4, 6}), 5.0);                 // beyond a rim: (3, 4)
  EXPECT_NEAR(flat->signed_distance({0, 0.5, 1.9}), -0.1, 1e-15);  // nearest an end

  const SolidPtr rounded =
      cylinder({.centre = {0, 0, 0}, .axis = {0, 0, 1}, .radius = 1.0, .half_length = 2.0, .rounded_ends = true});
  EXPECT_DOUBLE_EQ(rounded->signed_distance({0, 0, 3}), 0.0);  // the cap's pole
  EXPECT_NEAR(rounded->signed_distance({0, 3, 5}), std::hypot(3.0, 3.0) - 1.0, 1e-15);  // from the end point (0, 0, 2)
}

TEST(Solid, EveryPrimitiveIsExactAndLipschitz) {
  std::mt19937_64 rng(3);
  const SolidPtr flat = cylinder({.centre = {0.1, 0.2, -0.3}, .axis = {1, 2, 3}, .radius = 0.7, .half_length = 1.1});
  const SolidPtr rounded =
      cylinder({.centre = {0.1, 0.2, -0.3}, .axis = {1, 2, 3}, .radius = 0.7, .half_length = 1.1, .rounded_ends = true});
  for (const SolidPtr& s : {flat, rounded}) {
    check_exact(*s, rng, 500);
    check_lipschitz(*s, rng);
  }
}

TEST(Solid, SetOperationsClassifyAsTheSetLogicAndStayLipschitz) {
  const SolidPtr a = sphere({-0.4, 0, 0}, 1.0), b = box({-0.2, -0.6, -0.6}, {1.6, 0.6, 0.6});
  const SolidPtr u = unite({a, b}), i = intersect({a, b}), d = subtract(a, {b}), c = complement(a);
  std::mt19937_64 rng(4);
  int inside_difference = 0;
  for (int n = 0; n < 5000; ++n) {
    const Vector3d x = random_point(rng, 2.0);
    const bool in_a = a->signed_distance(x) < 0, in_b = b->signed_distance(x) < 0;
    EXPECT_EQ(u->signed_distance(x) < 0, in_a || in_b);
    EXPECT_EQ(i->signed_distance(x) < 0, in_a && in_b);
    EXPECT_EQ(d->signed_distance(x) < 0, in_a && !in_b);
    EXPECT_EQ(c->signed_distance(x) < 0, !in_a);
    inside_difference += in_a && !in_b;
  }
  EXPECT_GT(inside_difference, 100);
  for (const SolidPtr& s : {u, i, d, c}) check_lipschitz(*s, rng);
  // A tube's wall: outside a cylinder of radius 0.5 along x, the fluid inside it.
  const SolidPtr wall = complement(cylinder({.axis = {1, 0, 0}, .radius = 0.5}));
  EXPECT_DOUBLE_EQ(wall->signed_distance({3, 0, 0}), 0.5);  // the axis is fluid, 0.5 from the wall
  EXPECT_DOUBLE_EQ(wall->signed_distance({3, 0, 1}), -0.5);
}

TEST(Solid, TubeWithAConstrictionOrAnExpansionIsExact) {
  std::mt19937_64 rng(5);
  const Vector3d axis = Vector3d(1, 0.5, -0.25).normalized();
  for (const double throat : {0.4, 1.6}) {  // a constriction and an expansion of a unit tube
    const Tube t{.centre = {0.2, -0.1, 0.3}, .axis = axis, .far_radius = 1.0, .throat_radius = throat, .half_length = 1.5};
    const SolidPtr wall = tube_wall(t);
    // Far from the throat it is a straight tube's wall.
    const SolidPtr straight = complement(cylinder({.centre = t.centre, .axis = axis, .radius = 1.0}));
    const Vector3d across = axis.cross(Vector3d(Vector3d::UnitZ())).normalized();
    for (const double rho : {0.0, 0.3, 0.99, 1.2, 2.5}) {
      const Vector3d x = t.centre + 2.2 * axis + rho * across;  // the nearest profile point lies beyond the blend
      if (rho < 1.0 - 0.6) {
        EXPECT_NEAR(wall->signed_distance(x), straight->signed_distance(x), 1e-12) << "rho " << rho;
      }
    }
    // The throat: on the axis at the centre, the distance is at most the throat radius and
    // positive (fluid); on the wall there it is 0.
    EXPECT_GT(wall->signed_distance(t.centre), 0.0);
    EXPECT_LE(wall->signed_distance(t.centre), throat + 1e-15);
    EXPECT_NEAR(wall->signed_distance(t.centre + throat * across), 0.0, 1e-15);
    check_exact(*wall, rng, 400);
    check_lipschitz(*wall, rng);
  }
  EXPECT_THROW((void)tube_wall({.throat_radius = 0.0}), std::invalid_argument);
  EXPECT_THROW((void)tube_wall({.axis = {0, 0, 0}}), std::invalid_argument);
}

TEST(Solid, BadParametersAreRefused) {
  EXPECT_THROW((void)box({0, 0, 0}, {1, 0, 1}), std::invalid_argument);
  EXPECT_THROW((void)sphere({0, 0, 0}, 0.0), std::invalid_argument);
  EXPECT_THROW((void)sphere({0, NAN, 0}, 1.0), std::invalid_argument);
  EXPECT_THROW((void)cylinder({.axis = {0, 0, 0}}), std::invalid_argument);
  EXPECT_THROW((void)cylinder({.radius = -1.0}), std::invalid_argument);
  EXPECT_THROW((void)unite({}), std::invalid_argument);
  EXPECT_THROW((void)subtract(nullptr, {sphere({0, 0, 0}, 1)}), std::invalid_argument);
  EXPECT_THROW((void)complement(nullptr), std::invalid_argument);
}

}  // namespace
}  // namespace capsflow::geometry
