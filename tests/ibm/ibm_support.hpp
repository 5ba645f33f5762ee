#pragma once
// Shared fixtures of the ibm tests: small trees refined around a set of nodes, random
// node clouds, and sums over the max-level cells.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <random>

#include "ibm/kernels.hpp"
#include "ibm/refinement_tags.hpp"
#include "ibm/spread.hpp"
#include "tree/tree.hpp"

namespace capsflow::ibm::test {

// n nodes uniformly in the ball of radius r around c.
inline Eigen::Matrix3Xd random_ball(int n, double r, const Eigen::Vector3d& c, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd x(3, n);
  for (int i = 0; i < n;) {
    const Eigen::Vector3d p(u(gen), u(gen), u(gen));
    if (p.squaredNorm() > 1.0) continue;
    x.col(i++) = c + r * p;
  }
  return x;
}

inline Eigen::Matrix3Xd random_forces(Eigen::Index n, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd f(3, n);
  for (Eigen::Index i = 0; i < n; ++i) f.col(i) = Eigen::Vector3d(u(gen), u(gen), u(gen));
  return f;
}

// A tree on `options`, refined to its max level in the band of `band` cells around x and
// to `base` elsewhere.
inline tree::Tree<3> refined_around(const tree::TreeOptions<3>& options, const Eigen::Matrix3Xd& x, int band,
                                    int base = 1) {
  tree::Tree<3> t(options);
  MembraneTags tags;
  tags.build(options, options.max_level, band, x);
  t.refine_to([&](const tree::Box<3>& b) { return std::max(base, tags(b)); });
  return t;
}

// sum over the max-level active cells of f_c dx^3 and of (x_c - p) x f_c dx^3.
struct Totals {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();
};

inline Totals cell_totals(const tree::Tree<3>& t, const CellVector& f, const Eigen::Vector3d& p) {
  Totals s;
  const int l = t.max_level();
  const double v = std::pow(t.cell_size(l), 3);
  const auto& lv = t.level(l);
  for (Index c = lv.active_begin(); c < lv.active_end(); ++c) {
    const auto xc = t.center(c);
    const Eigen::Vector3d fc(f[0][c] * v, f[1][c] * v, f[2][c] * v);
    s.force += fc;
    s.torque += (Eigen::Vector3d(xc[0], xc[1], xc[2]) - p).cross(fc);
  }
  return s;
}

// The value of the cosine kernel's first moment at offset r (kernels.hpp).
inline double cosine_first_moment(double r) {
  const double q = 0.5 * std::acos(-1.0) * r;
  return 0.5 - r + 0.5 * (std::sin(q) - std::cos(q));
}

// The node's offset r in [0, 1) from the nearest lower cell centre along each axis.
inline Eigen::Vector3d offsets(const tree::Tree<3>& t, const Eigen::Vector3d& x) {
  const double h = t.cell_size(t.max_level());
  Eigen::Vector3d r;
  for (int d = 0; d < 3; ++d) {
    const double u = (x[d] - t.options().origin[d]) / h - 0.5;
    r[d] = u - std::floor(u);
  }
  return r;
}

}  // namespace capsflow::ibm::test
