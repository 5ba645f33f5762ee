#pragma once
// Shape diagnostics of a configuration (seed paper, "Criteria to be observed").
//
// Surface integrals over the discrete surface x(xi, eta) = sum_i N_i x_i (curved for P2),
// with n dS = (g1 x g2) dxi deta; volume moments by the divergence theorem:
//   S       = sum_e int |g1 x g2|,
//   V       = 1/3 sum_e int x . (g1 x g2),
//   int x_k dV       = sum_e int x_k^2/2 (g1 x g2)_k,
//   int x_k^2 dV     = sum_e int x_k^3/3 (g1 x g2)_k,
//   int x_j x_k dV   = sum_e int x_j^2 x_k/2 (g1 x g2)_j   (j != k).
// For P1 these are evaluated in closed form (signed tetrahedra on the origin). For P2 the
// integrands are polynomials of degree <= 8 in (xi, eta); the 25-point collapsed Gauss rule
// of degree 8 makes V, the centroid and the inertia tensor exact for the discrete surface
// (the P2 area integrand is not polynomial; its quadrature error is far below h^4).
// Coordinates are taken relative to the mean node position to avoid cancellation.
//
// Inertia ellipsoid: the ellipsoid with the same second moments J = int (x-c)(x-c)^T dV;
// its semi-axes are L_k = sqrt(5 mu_k / V) (mu_k eigenvalues of J) and D12 = (Lmax - Lmin) /
// (Lmax + Lmin). The seed's bounding-box variant: D12_bbox = (Lx - Ly)/(Lx + Ly) with
// Lx = max x - min x, Ly = max y - min y over the nodes; extent = (Lx, Ly, Lz), the lengths
// a capsule in a channel is measured by (Park & Dimitrakopoulos 2013, Huet & Wachs 2023).
#include "membrane/mesh.hpp"

#include <Eigen/Core>

namespace capsflow::membrane {

struct ShapeDiagnostics {
  double area = 0.0;
  double volume = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero();     // tr(J) 1 - J, unit density
  Eigen::Vector3d semi_axes = Eigen::Vector3d::Zero();   // inertia ellipsoid, descending
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();    // column k: direction of semi_axes[k]
  double d12 = 0.0;
  double d12_bbox = 0.0;
  Eigen::Vector3d extent = Eigen::Vector3d::Zero();      // the nodes' bounding box
};

// Throws std::invalid_argument if x does not have one column per mesh node.
[[nodiscard]] ShapeDiagnostics shape_diagnostics(const Mesh& mesh, const Eigen::Matrix3Xd& x);
[[nodiscard]] double surface_area(const Mesh& mesh, const Eigen::Matrix3Xd& x);
[[nodiscard]] double enclosed_volume(const Mesh& mesh, const Eigen::Matrix3Xd& x);
// D12 of the nodes' x-y bounding box, from their extents (ShapeDiagnostics::extent).
[[nodiscard]] double bounding_box_d12(const Eigen::Vector3d& extent);
// In a shear flow u = (G y, 0, 0) (the x-y plane the shear plane, z the vorticity axis):
// the inclination of the inertia ellipsoid's longest axis to x in that plane, in units of
// pi, in (-1/2, 1/2] (Ramanujan & Pozrikidis 1998 and most of the capsule literature plot
// theta / pi); and the membrane's tank-treading rate about z, the rate of the phase angle of
// Keller & Skalak (J. Fluid Mech. 120, 1982): with the shear-plane ellipse of the inertia
// ellipsoid (the x-y block of J: axes e1, e2 = z x e1, semi-axes a, b in the ratio of the
// square roots of its eigenvalues), X = r.e1 / a and Y = r.e2 / b for each node (r, w its
// position from the centroid and velocity relative to the nodes' mean),
//   phi' = sum_i (X_i Y'_i - Y_i X'_i) / sum_i (X_i^2 + Y_i^2),
// exact for their tank-treading field u = phi' (-(a/b) y, (b/a) x) on an ellipsoid and for a
// rigid rotation of a sphere; 2 pi / phi' is the period of a membrane point's turn.
[[nodiscard]] double inclination_xy(const ShapeDiagnostics& s);
[[nodiscard]] double tank_treading_rate(const ShapeDiagnostics& s, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& v);
// N_inf = max_i |x_i - y_i| (seed paper eq. 8); throws if the sizes differ.
[[nodiscard]] double max_node_distance(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& y);

}  // namespace capsflow::membrane
