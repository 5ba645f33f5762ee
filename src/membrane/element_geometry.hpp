#pragma once
// Shape functions of the P1 (3-node) and P2 (6-node) triangle on the reference triangle
// {xi >= 0, eta >= 0, xi + eta <= 1}, and the covariant tangent vectors of the map
// x(xi, eta) = sum_i N_i x_i:  g_1 = dx/dxi, g_2 = dx/deta.  The surface metric is
// g_ab = g_a . g_b and the area element dS = |g_1 x g_2| dxi deta.
//
// Node order: vertices 0, 1, 2 (counter-clockwise seen from outside), then for P2 the
// mid-edge nodes 3 = (0,1), 4 = (1,2), 5 = (2,0). With barycentric L0 = 1 - xi - eta,
// L1 = xi, L2 = eta: vertex N_k = L_k (2 L_k - 1), mid-edge N = 4 L_a L_b.
#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cstdint>

namespace capsflow::membrane {

template <int Nn>
struct ShapeValues {
  std::array<double, Nn> n;
  std::array<double, Nn> d_xi;
  std::array<double, Nn> d_eta;
};

template <int Nn>
[[nodiscard]] constexpr ShapeValues<Nn> shape_functions(double xi, double eta) noexcept {
  static_assert(Nn == 3 || Nn == 6, "P1 (3 nodes) or P2 (6 nodes) triangles only");
  ShapeValues<Nn> s{};
  const double l0 = 1.0 - xi - eta;
  const double l1 = xi;
  const double l2 = eta;
  if constexpr (Nn == 3) {
    s.n = {l0, l1, l2};
    s.d_xi = {-1.0, 1.0, 0.0};
    s.d_eta = {-1.0, 0.0, 1.0};
  } else {
    s.n = {l0 * (2 * l0 - 1), l1 * (2 * l1 - 1), l2 * (2 * l2 - 1), 4 * l0 * l1, 4 * l1 * l2,
           4 * l2 * l0};
    // dL0 = (-1, -1), dL1 = (1, 0), dL2 = (0, 1).
    s.d_xi = {-(4 * l0 - 1), 4 * l1 - 1, 0.0, 4 * (l0 - l1), 4 * l2, -4 * l2};
    s.d_eta = {-(4 * l0 - 1), 0.0, 4 * l2 - 1, -4 * l1, 4 * l1, 4 * (l0 - l2)};
  }
  return s;
}

// The element's node positions, gathered once per element from the global node array.
template <int Nn>
using ElementNodes = std::array<Eigen::Vector3d, Nn>;

template <int Nn>
[[nodiscard]] inline ElementNodes<Nn> gather(const Eigen::Matrix3Xd& x,
                                             const std::int32_t* connectivity) noexcept {
  ElementNodes<Nn> out;
  for (int i = 0; i < Nn; ++i) out[i] = x.col(connectivity[i]);
  return out;
}

struct Tangents {
  Eigen::Vector3d g1;
  Eigen::Vector3d g2;
};

template <int Nn>
[[nodiscard]] inline Tangents tangents(const ElementNodes<Nn>& x, const double* d_xi,
                                       const double* d_eta) noexcept {
  Tangents t{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  for (int i = 0; i < Nn; ++i) {
    t.g1 += d_xi[i] * x[i];
    t.g2 += d_eta[i] * x[i];
  }
  return t;
}

template <int Nn>
[[nodiscard]] inline Eigen::Vector3d interpolate(const ElementNodes<Nn>& x,
                                                 const double* n) noexcept {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int i = 0; i < Nn; ++i) p += n[i] * x[i];
  return p;
}

// Normal of the flat triangle through the three vertices (unnormalised, twice its area).
template <int Nn>
[[nodiscard]] inline Eigen::Vector3d chord_normal(const ElementNodes<Nn>& x) noexcept {
  return (x[1] - x[0]).cross(x[2] - x[0]);
}

}  // namespace capsflow::membrane
