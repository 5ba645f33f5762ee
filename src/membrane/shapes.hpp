#pragma once
// Initial shapes: deformed configurations obtained by mapping the reference nodes. The
// reference sphere stays the stress-free state; a P2 configuration is the quadratic
// interpolant of the mapped surface through its mapped nodes.
//   x = centre + A (X - centre)
// - the seed paper's ellipsoid: A = diag(2, 1/sqrt2, 1/sqrt2) (axes 2a, a/sqrt2, a/sqrt2,
//   same volume as the sphere);
// - uniform inflation by lambda: A = lambda I.
#include <Eigen/Core>

#include <concepts>

namespace capsflow::membrane {

// Throws std::invalid_argument if det A <= 0 (the map would invert the membrane).
[[nodiscard]] Eigen::Matrix3Xd map_linear(const Eigen::Matrix3Xd& reference, const Eigen::Matrix3d& a,
                                          const Eigen::Vector3d& centre);

[[nodiscard]] Eigen::Matrix3d seed_ellipsoid_matrix();

[[nodiscard]] Eigen::Matrix3Xd seed_ellipsoid(const Eigen::Matrix3Xd& reference,
                                              const Eigen::Vector3d& centre);

// Throws std::invalid_argument naming lambda unless 0 < lambda < infinity.
[[nodiscard]] Eigen::Matrix3Xd inflate(const Eigen::Matrix3Xd& reference, double lambda,
                                       const Eigen::Vector3d& centre);

// Any map of the reference nodes, x_i = f(X_i).
template <class F>
  requires std::invocable<F, const Eigen::Vector3d&>
[[nodiscard]] Eigen::Matrix3Xd map_nodes(const Eigen::Matrix3Xd& reference, F&& f) {
  Eigen::Matrix3Xd x(3, reference.cols());
  for (Eigen::Index i = 0; i < reference.cols(); ++i) x.col(i) = f(Eigen::Vector3d(reference.col(i)));
  return x;
}

}  // namespace capsflow::membrane
