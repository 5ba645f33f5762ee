// Least-squares wall gradients of the cut cells (why: wall_flux.hpp).
#include "fluid/multigrid/wall_flux.hpp"

#include <algorithm>
#include <bit>
#include <cmath>

#include <Eigen/Dense>

#include "fluid/multigrid/coefficients.hpp"
#include "tree/morton.hpp"
#include "tree/stencil.hpp"

namespace capsflow::fluid {

namespace {

// The smallest eigenvalue of the fit's normal matrix (in cells^2) below which the cells of a
// block do not span every direction around the wall: a gradient from them would be guessed.
constexpr double kMinSpread = 1e-3;
// The fit's weights 1 / (d^2 + kNearWeight), d a point's distance from the wall plane in
// cells. Measured against unweighted points (duct in a triangulated box, level 6): flow-rate
// error 5.0e-3 -> 6.6e-4 (the brick's walls: 9.4e-4); cylinder-array drag errors -0.8% ->
// -0.6%; multigrid cycles unchanged or one fewer. 0.1 gives 2.1e-3, 0.25 3.3e-3.
constexpr double kNearWeight = 0.03;
// How far (in cells) on the fluid side of the wall's plane a centre must lie to enter a fit.
constexpr double kFluidSide = 0.0;
// The band around the cut cells that the smoother relaxes again: two rings of neighbours.
// Measured (pipe Poisson, 256^2, 1e-11): cycles 27 without, 16 with one ring, 13 with two,
// 12 with three; the brick's walls alone take 12.
constexpr int kBandRings = 2;
// The net wall normal, relative to the wall's area, below which a cell has no wall flux.
constexpr double kNoNormal = 1e-9;
// How close to a grid axis a wall's normal, and to the line of a cell's centre its centroid
// (in cells), must be for the fit along that line (normal_column).
constexpr double kAligned = 1e-12;
// Cut cells of a level from which their fits run on several threads (an Eigen solve each).
constexpr Index kFitsParallelMin = 256;
// How close (relative) a closed-face cell's stencil must be to WallFlux::face_column_self() for
// the smoother to take the latter: a rounding's worth (the fit's centroids and centres are
// rounded differently at each cell), and a smoother needs no more.
constexpr double kSameColumn = 1e-12;

// The fit's weight of a point at distance `across` from the wall's plane (in cells).
double near_weight(double across) { return 1.0 / (across * across + kNearWeight); }

// A wall along a grid axis whose centroid lies on the line of c's centre: the points of the
// fit on that line (c and its neighbour into the fluid), else none. The fit's other points
// then only average the same normal gradient over the columns beside c (by symmetry they
// fit the tangential gradient apart), a tangential smoothing of O(h^2) that costs 17 reads
// instead of 1 per cut cell; on the line the fit is what Johansen & Colella's and Basilisk's
// normal probes read for such a wall (exact for linear a either way).
template <int D>
std::vector<std::pair<Index, Eigen::Matrix<double, D, 1>>> normal_column(
    const std::vector<std::pair<Index, Eigen::Matrix<double, D, 1>>>& points, const Eigen::Matrix<double, D, 1>& unit,
    const Eigen::Matrix<double, D, 1>& wall_offset) {
  int axis = 0;
  for (int d = 1; d < D; ++d)
    if (std::abs(unit[d]) > std::abs(unit[axis])) axis = d;
  for (int d = 0; d < D; ++d)
    if (d != axis && (std::abs(unit[d]) > kAligned || std::abs(wall_offset[d]) > kAligned)) return {};
  std::vector<std::pair<Index, Eigen::Matrix<double, D, 1>>> column;
  for (const auto& p : points) {
    bool on_line = true;
    for (int d = 0; d < D; ++d) on_line = on_line && (d == axis || std::abs(p.second[d]) <= kAligned);
    if (on_line) column.push_back(p);
  }
  return column;
}

// One cut cell's stencil: grad a(x_w) . N / h^D = self a_c + sum others + (-total) a_wall.
struct CellFit {
  bool flux = false;  // false: a coarse cell around a whole closed wall (no net normal)
  bool column = false, fallback = false;
  double self = 0.0, total = 0.0;
  std::vector<std::pair<Index, double>> others;
};

template <int D>
CellFit fit_cut_cell(const tree::Tree<D>& t, const EmbeddedGeometry<D>& geometry, int l, Index c) {
  using Vec = Eigen::Matrix<double, D, 1>;
  using Mat = Eigen::Matrix<double, D, D>;
  const tree::Level<D>& lv = t.level(l);
  const std::span<const double> volume = geometry.volume();
  const double h = t.cell_size(l), inv_volume = 1.0 / std::pow(h, D);
  CellFit fit;
  const bool leaf = lv.is_leaf(c);
  const tree::Point<D> centre = t.center(c), wall_centre = geometry.wall_centroid(c);
  const std::array<double, D> area = geometry.wall_normal_area(c);
  Vec n, xw;
  for (int d = 0; d < D; ++d) {
    n[d] = area[static_cast<std::size_t>(d)];
    xw[d] = (wall_centre[d] - centre[d]) / h;  // from c's centre, in cells
  }
  // A coarse cell around a whole closed wall (a root around a pipe) has no net normal:
  // no flux through it for any linear field, and no direction to fit along.
  if (!(n.norm() > kNoNormal * geometry.wall_area(c))) return fit;
  fit.flux = true;
  // The points: c and its same-level neighbours with fluid, relative to the wall centroid.
  std::vector<std::pair<Index, Vec>> points;
  const Vec into_fluid = -n.normalized();
  if (-xw.dot(into_fluid) >= kFluidSide) points.push_back({c, -xw});
  for (int s = 0; s < tree::kStencil<D>; ++s) {
    const Index k = lv.neighbor(c, s);
    if (k < lv.active_begin() || k >= lv.active_end() || !(volume[static_cast<std::size_t>(k)] > 0.0)) continue;
    if (leaf && !lv.is_leaf(k)) continue;
    Vec y;
    for (int d = 0; d < D; ++d) y[d] = tree::kOffsets<D>[static_cast<std::size_t>(s)][static_cast<std::size_t>(d)] - xw[d];
    if (y.dot(into_fluid) >= kFluidSide) points.push_back({k, y});
  }
  // Weighted by the inverse square of each point's distance from the wall's plane: the
  // nearest cells say most about the gradient there (a farther point adds the flow's
  // curvature across the wall, times its distance, to it).
  const Vec unit = n.normalized();
  auto omega = [&unit](const Vec& y) { return near_weight(y.dot(unit)); };
  // Each point's weight is omega(y) (q . y) / h^D: the fit's q = M^-1 N / h, or on a
  // column grad a . N = |N| sum_k omega_k s_k (a_k - a_wall) / (h sum_k omega_k s_k^2),
  // s_k = y_k . unit.
  std::vector<std::pair<Index, Vec>> used = normal_column(points, unit, xw);
  // A wall on a face of c (its centre half a cell from it): the brick's own walls' gradient,
  // (a_wall - a_c) / (h/2), from c alone. The fit with the next cell weakens the row's
  // diagonal (self -0.95 instead of -2 in 1/h^2, and -0.35 on that cell), and the
  // multigrid then took more cycles than with the brick's walls.
  const bool on_face = !used.empty() && used.front().first == c && used.front().second.dot(unit) <= -0.5 + kAligned;
  if (on_face) used.resize(1);
  Vec q = Vec::Zero();
  if (used.size() >= 2 || on_face) {
    double normal = 0.0;
    for (const auto& [k, y] : used) normal += omega(y) * y.dot(unit) * y.dot(unit);
    q = unit * (n.norm() / (normal * h));
    fit.column = true;
  } else {
    Mat m = Mat::Zero();
    for (const auto& [k, y] : points) m += omega(y) * y * y.transpose();
    const Eigen::SelfAdjointEigenSolver<Mat> spread(m, Eigen::EigenvaluesOnly);
    if (spread.eigenvalues().minCoeff() >= kMinSpread) {
      q = m.ldlt().solve(n) / h;
      used = std::move(points);
    } else {
      used.clear();
    }
  }
  if (!used.empty()) {
    for (const auto& [k, y] : used) {
      const double w = omega(y) * q.dot(y) * inv_volume;
      fit.total += w;
      if (k == c) fit.self = w;
      else fit.others.push_back({k, w});
    }
  } else {
    fit.fallback = true;
    const double length = n.norm();
    const double distance = std::max(n.dot(xw) / length, 0.5) * h;  // centre to the wall plane
    fit.self = -length / distance * inv_volume;
    fit.total = fit.self;
  }
  return fit;
}

}  // namespace

template <int D>
double WallFlux<D>::face_column_self() {
  // fit_cut_cell's stencil for a wall half a cell from the centre, |N| = h^(D-1): the centre
  // alone at -1/2 along the normal into the solid, (a_wall - a_c) / (1/2).
  return -2.0;
}

template <int D>
WallFlux<D>::WallFlux(const tree::Tree<D>& t, const EmbeddedGeometry<D>& geometry, Band band) : has_band_(band == Band::listed) {
  row_.assign(static_cast<std::size_t>(t.num_cells()), -1);
  face_column_.assign(static_cast<std::size_t>(t.num_cells()), 0);
  const double column_self = face_column_self();
  auto same = [](double a, double b) { return std::abs(a - b) <= kSameColumn * std::abs(b); };
  start_.assign(1, 0);
  cut_cells_.assign(static_cast<std::size_t>(t.depth() + 1), {});
  band_.assign(static_cast<std::size_t>(2 * (t.depth() + 1)), {});
  lagged_by_colour_.assign(static_cast<std::size_t>(2 * (t.depth() + 1)), {});
  const std::span<const double> volume = geometry.volume();
  std::vector<CellFit> fits;
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    // The fits in parallel (each cell's own arithmetic), then appended in the cut cells'
    // order: the same stencils as one by one.
    const auto cuts = geometry.cut_cells(l);
    const auto n = static_cast<Index>(cuts.size());
    fits.assign(cuts.size(), {});
#pragma omp parallel for schedule(dynamic, 64) if (n > kFitsParallelMin)
    for (Index i = 0; i < n; ++i) fits[static_cast<std::size_t>(i)] = fit_cut_cell(t, geometry, l, cuts[static_cast<std::size_t>(i)]);
    const double h2 = t.cell_size(l) * t.cell_size(l);
    auto colour_of = [&lv](Index c) {
      return std::popcount(lv.keys[static_cast<std::size_t>(c - lv.base)] & (tree::kChildren<D> - 1)) & 1;
    };
    for (std::size_t i = 0; i < cuts.size(); ++i) {
      const CellFit& fit = fits[i];
      if (!fit.flux) continue;
      const Index c = cuts[i];
      row_[static_cast<std::size_t>(c)] = static_cast<std::int32_t>(self_.size());
      cut_cells_[static_cast<std::size_t>(l)].push_back(c);
      bool lagged = false;
      for (const auto& [k, w] : fit.others) {
        cell_.push_back(k);
        weight_.push_back(w);
        lagged = lagged || (w != 0.0 && colour_of(k) == colour_of(c));
      }
      if (lagged) lagged_by_colour_[static_cast<std::size_t>(2 * l + colour_of(c))].push_back(c);
      const std::uint8_t flag = geometry.uniform()[static_cast<std::size_t>(c)];
      if (closed_face_stencil(flag) && fit.others.empty())
        face_column_[static_cast<std::size_t>(c)] = same(fit.self * h2, column_self);
      lagged_.push_back(lagged);
      columns_ += fit.column;
      fallbacks_ += fit.fallback;
      self_.push_back(fit.self);
      wall_.push_back(-fit.total);
      start_.push_back(static_cast<std::int32_t>(cell_.size()));
    }
    if (!has_band_) continue;
    // The band: the cut cells and their neighbours with fluid, by colour.
    std::vector<Index> near(cut_cells_[static_cast<std::size_t>(l)]);
    for (int ring = 0; ring < kBandRings; ++ring) {
      const std::size_t n_near = near.size();
      for (std::size_t i = 0; i < n_near; ++i) {
        const Index c = near[i];
        for (int s = 0; s < tree::kStencil<D>; ++s) {
          const Index k = lv.neighbor(c, s);
          if (k >= lv.active_begin() && k < lv.active_end() && volume[static_cast<std::size_t>(k)] > 0.0) near.push_back(k);
        }
      }
      std::sort(near.begin(), near.end());
      near.erase(std::unique(near.begin(), near.end()), near.end());
    }
    // N ranks: the cells this rank relaxes (the others' values come by the exchanges).
    const bool every_cell = !t.distributed() || t.replicated_level(l);
    for (const Index c : near) {
      if (!every_cell && !t.owns(c)) continue;
      band_[static_cast<std::size_t>(2 * l + colour_of(c))].push_back(c);
    }
  }
}

template class WallFlux<2>;
template class WallFlux<3>;

}  // namespace capsflow::fluid
