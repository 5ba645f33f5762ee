// Shape diagnostics; the integrals and the inertia ellipsoid are stated in diagnostics.hpp.
#include "membrane/diagnostics.hpp"

#include "membrane/element_geometry.hpp"
#include "membrane/quadrature.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace capsflow::membrane {

namespace {

constexpr int n_moments = 11;  // area, volume, 3 first moments, 6 second moments
using Moments = std::array<double, n_moments>;

// P1: the surface integrals of a flat triangle (a, b, c) in closed form, through the signed
// tetrahedron (0, a, b, c): V = a . (b x c)/6, int x dV = V s/4, int x_j x_k dV =
// V/20 (sum_v v_j v_k + s_j s_k), s = a + b + c (the origin contributes nothing).
inline void triangle_moments(const ElementNodes<3>& x, Moments& m) noexcept {
  const Eigen::Vector3d& a = x[0];
  const Eigen::Vector3d& b = x[1];
  const Eigen::Vector3d& c = x[2];
  const double v = a.dot(b.cross(c)) / 6.0;
  const Eigen::Vector3d s = a + b + c;
  const Eigen::Matrix3d second = (v / 20.0) * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  m[0] += 0.5 * (b - a).cross(c - a).norm();
  m[1] += v;
  for (int k = 0; k < 3; ++k) {
    m[2 + k] += 0.25 * v * s[k];
    m[5 + k] += second(k, k);
  }
  m[8] += second(0, 1);
  m[9] += second(0, 2);
  m[10] += second(1, 2);
}

// P2: the collapsed Gauss rule exact for degree 8, as matrices so that the positions and
// tangents at all points are three small matrix products per element.
constexpr int p2_points_per_direction = 5;  // degree 2 * 5 - 2 = 8
constexpr int p2_points = p2_points_per_direction * p2_points_per_direction;
struct P2MomentRule {
  Eigen::Matrix<double, 6, p2_points> n, d_xi, d_eta;
  Eigen::Array<double, 1, p2_points> w;
};

const P2MomentRule& p2_moment_rule() {
  static const P2MomentRule rule = [] {
    P2MomentRule r;
    const QuadratureRule& q = gauss_rule(p2_points_per_direction);
    for (int k = 0; k < p2_points; ++k) {
      const auto& p = q.points[static_cast<std::size_t>(k)];
      const auto s = shape_functions<6>(p.xi, p.eta);
      for (int i = 0; i < 6; ++i) {
        r.n(i, k) = s.n[static_cast<std::size_t>(i)];
        r.d_xi(i, k) = s.d_xi[static_cast<std::size_t>(i)];
        r.d_eta(i, k) = s.d_eta[static_cast<std::size_t>(i)];
      }
      r.w(k) = p.weight;
    }
    return r;
  }();
  return rule;
}

inline void curved_triangle_moments(const ElementNodes<6>& x, const P2MomentRule& rule, Moments& m) noexcept {
  Eigen::Matrix<double, 3, 6> xe;
  for (int i = 0; i < 6; ++i) xe.col(i) = x[i];
  using Points = Eigen::Array<double, 3, p2_points>;
  const Points p = (xe * rule.n).array();
  const Points g1 = (xe * rule.d_xi).array();
  const Points g2 = (xe * rule.d_eta).array();
  Points n;  // w (g1 x g2)
  n.row(0) = (g1.row(1) * g2.row(2) - g1.row(2) * g2.row(1)) * rule.w;
  n.row(1) = (g1.row(2) * g2.row(0) - g1.row(0) * g2.row(2)) * rule.w;
  n.row(2) = (g1.row(0) * g2.row(1) - g1.row(1) * g2.row(0)) * rule.w;
  m[0] += n.matrix().colwise().norm().sum();
  m[1] += (p * n).sum() / 3.0;
  for (int k = 0; k < 3; ++k) {
    m[2 + k] += 0.5 * (p.row(k).square() * n.row(k)).sum();
    m[5 + k] += (p.row(k).cube() * n.row(k)).sum() / 3.0;
  }
  m[8] += 0.5 * (p.row(0).square() * p.row(1) * n.row(0)).sum();
  m[9] += 0.5 * (p.row(0).square() * p.row(2) * n.row(0)).sum();
  m[10] += 0.5 * (p.row(1).square() * p.row(2) * n.row(1)).sum();
}

// The sums are the same to the last bit on any number of threads (diagnostics.csv must not
// depend on OMP_NUM_THREADS): each block of kBlock consecutive elements is summed in element
// order by one thread, then the block sums in block order by one thread. An OpenMP
// reduction would add the threads' partial sums, whose split depends on the thread count.
constexpr std::int64_t kBlock = 64;

template <int Nn>
Moments integrate(const Mesh& mesh, const Eigen::Matrix3Xd& x, const Eigen::Vector3d& origin) {
  const std::int64_t n_elements = mesh.element_count();
  const std::int64_t n_blocks = (n_elements + kBlock - 1) / kBlock;
  const std::int32_t* conn = mesh.elements.data();
  std::vector<Moments> block_sums(static_cast<std::size_t>(n_blocks));
#pragma omp parallel for schedule(static)
  for (std::int64_t b = 0; b < n_blocks; ++b) {
    Moments m{};
    for (std::int64_t e = b * kBlock; e < std::min(n_elements, (b + 1) * kBlock); ++e) {
      auto xe = gather<Nn>(x, conn + e * Nn);
      for (auto& p : xe) p -= origin;
      if constexpr (Nn == 3) triangle_moments(xe, m);
      else curved_triangle_moments(xe, p2_moment_rule(), m);
    }
    block_sums[static_cast<std::size_t>(b)] = m;
  }
  Moments out{};
  for (const Moments& m : block_sums)
    for (std::size_t k = 0; k < out.size(); ++k) out[k] += m[k];
  return out;
}

void check_sizes(const Mesh& mesh, const Eigen::Matrix3Xd& x) {
  if (x.cols() != mesh.node_count())
    throw std::invalid_argument("shape diagnostics: configuration has " + std::to_string(x.cols()) +
                                " nodes, the mesh " + std::to_string(mesh.node_count()));
}

Moments moments(const Mesh& mesh, const Eigen::Matrix3Xd& x, const Eigen::Vector3d& origin) {
  check_sizes(mesh, x);
  (void)p2_moment_rule();  // built before the parallel region
  return with_element_nodes(mesh.order, [&](auto nn) { return integrate<nn()>(mesh, x, origin); });
}

}  // namespace

double bounding_box_d12(const Eigen::Vector3d& extent) {
  return (extent[0] - extent[1]) / (extent[0] + extent[1]);
}

double max_node_distance(const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& y) {
  if (x.cols() != y.cols())
    throw std::invalid_argument("max_node_distance: configurations have " + std::to_string(x.cols()) +
                                " and " + std::to_string(y.cols()) + " nodes");
  return x.cols() == 0 ? 0.0 : (x - y).colwise().norm().maxCoeff();
}

double surface_area(const Mesh& mesh, const Eigen::Matrix3Xd& x) {
  return moments(mesh, x, x.rowwise().mean())[0];
}

double enclosed_volume(const Mesh& mesh, const Eigen::Matrix3Xd& x) {
  return moments(mesh, x, x.rowwise().mean())[1];
}

ShapeDiagnostics shape_diagnostics(const Mesh& mesh, const Eigen::Matrix3Xd& x) {
  const Eigen::Vector3d origin = x.rowwise().mean();
  const Moments m = moments(mesh, x, origin);
  ShapeDiagnostics d;
  d.area = m[0];
  d.volume = m[1];
  const Eigen::Vector3d first(m[2], m[3], m[4]);
  const Eigen::Vector3d c = first / d.volume;  // centroid relative to origin
  Eigen::Matrix3d j;
  j << m[5], m[8], m[9], m[8], m[6], m[10], m[9], m[10], m[7];
  j -= d.volume * c * c.transpose();  // second moments about the centroid
  d.centroid = origin + c;
  d.inertia = j.trace() * Eigen::Matrix3d::Identity() - j;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(j);  // ascending eigenvalues
  for (int k = 0; k < 3; ++k) {
    d.semi_axes[k] = std::sqrt(std::max(0.0, 5.0 * eig.eigenvalues()[2 - k] / d.volume));
    d.axes.col(k) = eig.eigenvectors().col(2 - k);
  }
  d.d12 = (d.semi_axes[0] - d.semi_axes[2]) / (d.semi_axes[0] + d.semi_axes[2]);
  d.extent = x.rowwise().maxCoeff() - x.rowwise().minCoeff();
  d.d12_bbox = bounding_box_d12(d.extent);
  return d;
}

double inclination_xy(const ShapeDiagnostics& s) {
  const Eigen::Vector3d a = s.axes.col(0);
  double theta = std::atan2(a.y(), a.x()) / std::numbers::pi;  // (-1, 1]: an axis, not a direction
  if (theta > 0.5) theta -= 1.0;
  if (theta <= -0.5) theta += 1.0;
  return theta;
}

double tank_treading_rate(const ShapeDiagnostics& s, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& v) {
  if (x.cols() != v.cols() || x.cols() == 0)
    throw std::invalid_argument("tank_treading_rate: positions and velocities differ in size");
  // J = int (x - c)(x - c)^T dV from the stored tr(J) 1 - J.
  const Eigen::Matrix3d j = 0.5 * s.inertia.trace() * Eigen::Matrix3d::Identity() - s.inertia;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(j.topLeftCorner<2, 2>());
  const Eigen::Vector2d e1 = eig.eigenvectors().col(1), e2(-e1.y(), e1.x());  // e2 = z x e1
  const double a = std::sqrt(std::max(eig.eigenvalues()[1], 0.0)), b = std::sqrt(std::max(eig.eigenvalues()[0], 0.0));
  if (!(b > 0.0)) return 0.0;
  const Eigen::Vector3d vc = v.rowwise().mean();
  double moment = 0.0, norm = 0.0;
  for (Eigen::Index i = 0; i < x.cols(); ++i) {
    const Eigen::Vector2d r(x(0, i) - s.centroid.x(), x(1, i) - s.centroid.y());
    const Eigen::Vector2d w(v(0, i) - vc.x(), v(1, i) - vc.y());
    const double px = r.dot(e1) / a, py = r.dot(e2) / b, wx = w.dot(e1) / a, wy = w.dot(e2) / b;
    moment += px * wy - py * wx;
    norm += px * px + py * py;
  }
  return norm > 0.0 ? moment / norm : 0.0;
}

}  // namespace capsflow::membrane
