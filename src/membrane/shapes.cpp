// Initial shapes as linear maps of the reference nodes (shapes.hpp).
#include "membrane/shapes.hpp"

#include <Eigen/LU>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace capsflow::membrane {

Eigen::Matrix3Xd map_linear(const Eigen::Matrix3Xd& reference, const Eigen::Matrix3d& a,
                            const Eigen::Vector3d& centre) {
  const double det = a.determinant();
  if (!(det > 0.0) || !std::isfinite(det)) {
    std::ostringstream msg;
    msg << "map_linear: det A = " << det << " must be positive (the map would invert the membrane)";
    throw std::invalid_argument(msg.str());
  }
  return (a * (reference.colwise() - centre)).colwise() + centre;
}

Eigen::Matrix3d seed_ellipsoid_matrix() {
  return Eigen::Vector3d(2.0, 1.0 / std::sqrt(2.0), 1.0 / std::sqrt(2.0)).asDiagonal();
}

Eigen::Matrix3Xd seed_ellipsoid(const Eigen::Matrix3Xd& reference, const Eigen::Vector3d& centre) {
  return map_linear(reference, seed_ellipsoid_matrix(), centre);
}

Eigen::Matrix3Xd inflate(const Eigen::Matrix3Xd& reference, double lambda, const Eigen::Vector3d& centre) {
  if (!(lambda > 0.0) || !std::isfinite(lambda)) {
    std::ostringstream msg;
    msg << "inflate: stretch ratio lambda = " << lambda << " must be positive and finite";
    throw std::invalid_argument(msg.str());
  }
  return map_linear(reference, lambda * Eigen::Matrix3d::Identity(), centre);
}

}  // namespace capsflow::membrane
