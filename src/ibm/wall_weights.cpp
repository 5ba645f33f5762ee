// The open fractions of the face stencils of nodes next to embedded walls (wall_weights.hpp).
#include "ibm/wall_weights.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "geometry/cut_cell.hpp"

namespace capsflow::ibm {

namespace {
constexpr Eigen::Index kParallelNodes = 256;
// The grid points (max-level cell corners) around a node: at most the widest stencil box
// plus one point per axis.
constexpr int kMaxPoints = kMaxBoxWidth + 1;

// phi at the corners of the max-level cells, on a box of grid points from `lo`, wrapped
// across periodic sides as fluid::EmbeddedGeometry wraps them (the same points, the same
// numbers).
struct CornerValues {
  tree::Coords<3> lo{};
  std::array<int, 3> n{};
  std::array<double, kMaxPoints * kMaxPoints * kMaxPoints> phi{};
  double at(int i, int j, int k) const { return phi[static_cast<std::size_t>(i + n[0] * (j + n[1] * k))]; }
};

void evaluate_corners(const fluid::EmbeddedGeometry<3>& walls, const tree::TreeOptions<3>& o, double h, int level,
                      CornerValues& cv) {
  for (int k = 0; k < cv.n[2]; ++k)
    for (int j = 0; j < cv.n[1]; ++j)
      for (int i = 0; i < cv.n[0]; ++i) {
        const std::array<int, 3> offset{i, j, k};
        tree::Point<3> x{};
        for (int d = 0; d < 3; ++d) {
          std::int64_t g = static_cast<std::int64_t>(cv.lo[d]) + offset[static_cast<std::size_t>(d)];
          if (o.periodic[d]) {
            const std::int64_t cells = static_cast<std::int64_t>(o.roots[d]) << level;
            g = ((g % cells) + cells) % cells;
          }
          x[d] = o.origin[d] + static_cast<double>(g) * h;
        }
        cv.phi[static_cast<std::size_t>(i + cv.n[0] * (j + cv.n[1] * k))] = walls.signed_distance(x);
      }
}

}  // namespace

void WallWeights::clear() {
  entry_.clear();
  open_.clear();
  inverse_sum_.clear();
  renormalised_.clear();
  near_ = 0;
  buried_ = -1;
}

void WallWeights::find(KernelKind kind, bool divergence_free, const fluid::EmbeddedGeometry<3>& walls,
                       const tree::Tree<3>& t, Eigen::Ref<const Eigen::Matrix3Xd> x, double reach) {
  with_face_kernel(kind, divergence_free, [&]<Kernel K>(K) { find_with<K>(walls, t, x, reach); });
}

template <Kernel K>
void WallWeights::find_with(const fluid::EmbeddedGeometry<3>& walls, const tree::Tree<3>& t,
                            Eigen::Ref<const Eigen::Matrix3Xd> x, double reach) {
  clear();
  const tree::TreeOptions<3>& o = t.options();
  const int level = t.max_level();
  const double h = t.cell_size(level);
  const Eigen::Index n = x.cols();
  if (n == 0) return;
  // One distance for a membrane far from every wall: phi is 1-Lipschitz, so the nodes lie at
  // least phi(centre) - (their farthest distance from the centre) from the walls.
  const Eigen::Vector3d centre = x.rowwise().mean();
  const double extent = (x.colwise() - centre).colwise().norm().maxCoeff();
  if (walls.signed_distance({centre[0], centre[1], centre[2]}) - extent > reach) return;

  entry_.assign(static_cast<std::size_t>(n), -1);
#pragma omp parallel for schedule(static) if (n >= kParallelNodes)
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(walls.signed_distance({x(0, i), x(1, i), x(2, i)}) > reach)) entry_[static_cast<std::size_t>(i)] = 0;
  std::int32_t entries = 0;
  for (auto& e : entry_)
    if (e == 0) e = entries++;
  near_ = entries;
  if (entries == 0) {
    entry_.clear();
    return;
  }
  stride_ = 0;
  const double x0[3] = {x(0, 0), x(1, 0), x(2, 0)};
  for (int d = 0; d < 3; ++d) stride_ = std::max(stride_, face_stencil_bounds<K>(o, h, x0, d).size());
  open_.assign(static_cast<std::size_t>(3 * entries) * stride_, 0.0);
  inverse_sum_.assign(static_cast<std::size_t>(3 * entries), 1.0);
  renormalised_.assign(static_cast<std::size_t>(3 * entries), 0);
  Eigen::Index buried = n;

#pragma omp parallel for schedule(dynamic, 16) reduction(min : buried) if (entries >= 64)
  for (Eigen::Index i = 0; i < n; ++i) {
    const std::int32_t e = entry_[static_cast<std::size_t>(i)];
    if (e < 0) continue;
    const double xi[3] = {x(0, i), x(1, i), x(2, i)};
    std::array<BoxStencil, 3> st;
    CornerValues cv;
    for (int d = 0; d < 3; ++d) {
      st[d] = face_stencil<K>(o, h, xi, d);
      for (int a = 0; a < 3; ++a) {
        const int lo = d == 0 ? st[d].first[a] : std::min(cv.lo[a], st[d].first[a]);
        const int hi = d == 0 ? st[d].first[a] + st[d].n[a] : std::max(cv.lo[a] + cv.n[a] - 1, st[d].first[a] + st[d].n[a]);
        cv.lo[a] = lo;
        cv.n[a] = hi - lo + 1;
      }
    }
    evaluate_corners(walls, o, h, level, cv);
    for (int d = 0; d < 3; ++d) {
      const int a1 = (d + 1) % 3, a2 = (d + 2) % 3;
      // face_fraction's corner order: the lower remaining axis first.
      const int p = std::min(a1, a2), q = std::max(a1, a2);
      double* open = open_.data() + static_cast<std::size_t>(3 * e + d) * stride_;
      bool all_open = true;
      for (int kz = 0, s = 0; kz < st[d].n[2]; ++kz)
        for (int jy = 0; jy < st[d].n[1]; ++jy)
          for (int ix = 0; ix < st[d].n[0]; ++ix, ++s) {
            const std::array<int, 3> cell{st[d].first[0] + ix - cv.lo[0], st[d].first[1] + jy - cv.lo[1],
                                          st[d].first[2] + kz - cv.lo[2]};
            std::array<double, 4> corner{};
            for (int b = 0; b < 4; ++b) {
              std::array<int, 3> g = cell;
              g[static_cast<std::size_t>(p)] += b & 1;
              g[static_cast<std::size_t>(q)] += (b >> 1) & 1;
              corner[static_cast<std::size_t>(b)] = cv.at(g[0], g[1], g[2]);
            }
            open[s] = geometry::face_fraction<3>(corner);
            all_open = all_open && open[s] == 1.0;
          }
      if (all_open) continue;
      const double sum = box_sum(st[d], open);
      if (!(sum > 0.0)) {
        buried = std::min(buried, i);
        continue;
      }
      renormalised_[static_cast<std::size_t>(3 * e + d)] = 1;
      inverse_sum_[static_cast<std::size_t>(3 * e + d)] = 1.0 / sum;
    }
  }
  buried_ = buried < n ? buried : -1;
}

}  // namespace capsflow::ibm
