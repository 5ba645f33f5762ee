// Interpolating cell or face velocities at membrane nodes (operators: interpolate.hpp).
#include "ibm/interpolate.hpp"

#include <algorithm>
#include <stdexcept>

#include <fmt/format.h>

#include "ibm/stencil.hpp"

namespace capsflow::ibm {

namespace {
constexpr Eigen::Index kParallelNodes = 256;
// Every component has one value per cell of t (a field kept across an adapt must have been
// resized with it).
template <class Components>
void require_cell_sized(const tree::Tree<3>& t, const Components& u, const char* what) {
  for (const auto& ud : u)
    if (ud.size() != static_cast<std::size_t>(t.num_cells()))
      throw std::invalid_argument(
          fmt::format("ibm: interpolate from a {} of {} slots, the tree has {} cells", what, ud.size(), t.num_cells()));
}

// Next to an embedded wall, each value times its slot's interpolation factor
// (wall_weights.hpp); one definition for the one-rank and the routed sums.
void apply_wall_factors(const WallWeights* walls, Eigen::Index i, int d, int size, double* values) {
  const double* open = walls ? walls->open(i, d) : nullptr;
  if (!open) return;
  const double inverse_sum = walls->inverse_sum(i, d);
  for (int s = 0; s < size; ++s) values[s] *= interpolation_factor(open[s], inverse_sum);
}

}  // namespace

template <Kernel K>
void interpolate(const tree::Tree<3>& t, const std::array<std::span<const double>, 3>& u,
                 const Eigen::Matrix3Xd& x, Eigen::Matrix3Xd& v) {
  constexpr int W = K::kSupport, W3 = W * W * W;
  require_cell_sized(t, u, "field");
  const Eigen::Index n = x.cols();
  v.resize(3, n);
  const int level = t.max_level();
  const double h = t.cell_size(level);
  const auto& options = t.options();
  Eigen::Index bad = n;

#pragma omp parallel for schedule(static) reduction(min : bad) if (n >= kParallelNodes)
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto st = node_stencil<K>(options, h, &x(0, i));
    Index c[W3];
    if (find_patch<W>(t, level, {st[0].first, st[1].first, st[2].first}, c) >= 0) {
      bad = std::min(bad, i);
      continue;
    }
    double s0 = 0.0, s1 = 0.0, s2 = 0.0;
    for (int kz = 0, s = 0; kz < W; ++kz)
      for (int jy = 0; jy < W; ++jy) {
        const double wyz = st[2].w[kz] * st[1].w[jy];
        for (int ix = 0; ix < W; ++ix, ++s) {
          const double wc = wyz * st[0].w[ix];
          s0 += u[0][c[s]] * wc;
          s1 += u[1][c[s]] * wc;
          s2 += u[2][c[s]] * wc;
        }
      }
    v(0, i) = s0;
    v(1, i) = s1;
    v(2, i) = s2;
  }
  if (bad < n) {
    const auto st = node_stencil<K>(options, h, &x(0, bad));
    Index c[W3];
    require_patch<W>(t, level, {st[0].first, st[1].first, st[2].first}, c, bad, &x(0, bad), "interpolation",
                     K::kName);
  }
}

template <Kernel K>
void interpolate_faces(const tree::Tree<3>& t, const fluid::FaceField<3>& uf, const Eigen::Matrix3Xd& x,
                       Eigen::Matrix3Xd& v, const NodeBoxes* boxes, const WallWeights* walls) {
  constexpr int kMaxCells = kMaxBoxWidth * kMaxBoxWidth * kMaxBoxWidth;
  require_cell_sized(t, uf, "face field");
  const Eigen::Index n = x.cols();
  CAPSFLOW_ASSERT(!boxes || boxes->nodes() == n, "ibm: interpolating with the boxes of other nodes");
  v.resize(3, n);
  const int level = t.max_level();
  const double h = t.cell_size(level);
  const auto& options = t.options();
  Eigen::Index bad = n;

#pragma omp parallel for schedule(static) reduction(min : bad) if (n >= kParallelNodes)
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) {
      const BoxStencil st = face_stencil<K>(options, h, &x(0, i), d);
      Index c[kMaxCells];
      if (!(boxes && boxes->stencil_cells(i, st, c)) && find_box(t, level, st.first, st.n, c) >= 0) {
        bad = std::min(bad, i);
        break;
      }
      const double* u = uf[d].data();
      double values[kMaxCells];
      for (int s = 0; s < st.size(); ++s) values[s] = u[c[s]];
      apply_wall_factors(walls, i, d, st.size(), values);
      v(d, i) = box_sum(st, values);
    }
  }
  if (bad < n) {
    for (int d = 0; d < 3; ++d) {
      const BoxStencil st = face_stencil<K>(options, h, &x(0, bad), d);
      Index c[kMaxCells];
      require_box(t, level, st.first, st.n, c, bad, &x(0, bad), "face interpolation", K::kName);
    }
  }
}

template <Kernel K>
void interpolate_faces_owned(const tree::Tree<3>& t, const fluid::FaceField<3>& uf, const Eigen::Matrix3Xd& x,
                             const OwnedPositions& own, PartialVelocities& out, const NodeBoxes* boxes,
                             const WallWeights* walls) {
  constexpr int kMaxCells = kMaxBoxWidth * kMaxBoxWidth * kMaxBoxWidth;
  require_cell_sized(t, uf, "face field");
  const Eigen::Index n = x.cols();
  CAPSFLOW_ASSERT(!boxes || boxes->nodes() == n, "ibm: interpolating with the boxes of other nodes");
  out.kind.assign(static_cast<std::size_t>(3 * n), PartialVelocities::kNothing);
  out.sum.assign(static_cast<std::size_t>(3 * n), 0.0);
  out.offset.assign(static_cast<std::size_t>(3 * n), 0);
  out.count.assign(static_cast<std::size_t>(3 * n), 0);
  out.slots.clear();
  out.values.clear();
  const int level = t.max_level();
  const double h = t.cell_size(level);
  for (Eigen::Index i = 0; i < n; ++i) {
    const NodeBoxes::Interpolator who = boxes ? boxes->interpolator(i) : NodeBoxes::Interpolator::parts;
    if (who == NodeBoxes::Interpolator::elsewhere) continue;
    // Interpolated here: every cell of the stencil is held (owned or ghost), so each sum is
    // whole; else this rank's own cells.
    const bool here = who == NodeBoxes::Interpolator::here;
    for (int d = 0; d < 3; ++d) {
      const BoxStencil st = face_stencil<K>(t.options(), h, &x(0, i), d);
      Index c[kMaxCells];
      if (here) {
        if (!boxes->held_stencil_cells(i, st, c))
          require_box(t, level, st.first, st.n, c, i, &x(0, i), "face interpolation", K::kName);
      } else if (!(boxes && boxes->stencil_cells(i, st, c))) {
        require_box(t, level, st.first, st.n, c, i, &x(0, i), "face interpolation", K::kName, own);
      }
      const double* u = uf[d].data();
      const auto k = static_cast<std::size_t>(3 * i + d);
      int present = 0;  // cells of the stencil found here
      for (int s = 0; s < st.size(); ++s) present += c[s] != tree::kNone;
      if (present == 0) continue;
      const double* open = walls ? walls->open(i, d) : nullptr;
      const double inverse_sum = open ? walls->inverse_sum(i, d) : 1.0;
      if (present == st.size()) {  // the whole sum here, in box_sum's order
        double values[kMaxCells];
        for (int s = 0; s < st.size(); ++s) values[s] = u[c[s]];
        apply_wall_factors(walls, i, d, st.size(), values);
        out.kind[k] = PartialVelocities::kSum;
        out.sum[k] = box_sum(st, values);
        continue;
      }
      out.kind[k] = PartialVelocities::kSlots;
      out.offset[k] = static_cast<std::uint32_t>(out.values.size());
      out.count[k] = static_cast<std::uint32_t>(present);
      for (int s = 0; s < st.size(); ++s)
        if (c[s] != tree::kNone) {
          out.slots.push_back(static_cast<std::uint16_t>(s));
          out.values.push_back(open ? u[c[s]] * interpolation_factor(open[s], inverse_sum) : u[c[s]]);
        }
    }
  }
}

template <Kernel K>
double complete_face_velocity(const tree::TreeOptions<3>& options, double h, const double* x, int d,
                              std::span<const double> values) {
  const BoxStencil st = face_stencil<K>(options, h, x, d);
  if (values.size() != static_cast<std::size_t>(st.size()))
    throw std::logic_error(fmt::format("ibm: {} gathered values for a stencil of {} cells", values.size(), st.size()));
  return box_sum(st, values.data());
}

template void interpolate_faces_owned<CosineKernel>(const tree::Tree<3>&, const fluid::FaceField<3>&,
                                                    const Eigen::Matrix3Xd&, const OwnedPositions&, PartialVelocities&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces_owned<HatKernel>(const tree::Tree<3>&, const fluid::FaceField<3>&,
                                                 const Eigen::Matrix3Xd&, const OwnedPositions&, PartialVelocities&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces_owned<Peskin4Kernel>(const tree::Tree<3>&, const fluid::FaceField<3>&,
                                                     const Eigen::Matrix3Xd&, const OwnedPositions&, PartialVelocities&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces_owned<DivergenceFree<CosineKernel>>(const tree::Tree<3>&, const fluid::FaceField<3>&,
    const Eigen::Matrix3Xd&, const OwnedPositions&, PartialVelocities&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces_owned<DivergenceFree<HatKernel>>(const tree::Tree<3>&, const fluid::FaceField<3>&,
    const Eigen::Matrix3Xd&, const OwnedPositions&, PartialVelocities&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces_owned<DivergenceFree<Peskin4Kernel>>(const tree::Tree<3>&, const fluid::FaceField<3>&,
    const Eigen::Matrix3Xd&, const OwnedPositions&, PartialVelocities&, const NodeBoxes*, const WallWeights*);
template double complete_face_velocity<CosineKernel>(const tree::TreeOptions<3>&, double, const double*, int,
                                                     std::span<const double>);
template double complete_face_velocity<HatKernel>(const tree::TreeOptions<3>&, double, const double*, int,
                                                  std::span<const double>);
template double complete_face_velocity<Peskin4Kernel>(const tree::TreeOptions<3>&, double, const double*, int,
                                                      std::span<const double>);
template double complete_face_velocity<DivergenceFree<CosineKernel>>(const tree::TreeOptions<3>&, double,
                                                                     const double*, int, std::span<const double>);
template double complete_face_velocity<DivergenceFree<HatKernel>>(const tree::TreeOptions<3>&, double, const double*,
                                                                  int, std::span<const double>);
template double complete_face_velocity<DivergenceFree<Peskin4Kernel>>(const tree::TreeOptions<3>&, double,
                                                                      const double*, int, std::span<const double>);

template void interpolate_faces<CosineKernel>(const tree::Tree<3>&, const fluid::FaceField<3>&,
                                              const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces<HatKernel>(const tree::Tree<3>&, const fluid::FaceField<3>&, const Eigen::Matrix3Xd&,
                                           Eigen::Matrix3Xd&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces<Peskin4Kernel>(const tree::Tree<3>&, const fluid::FaceField<3>&,
                                               const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&, const NodeBoxes*, const WallWeights*);

template void interpolate<CosineKernel>(const tree::Tree<3>&, const std::array<std::span<const double>, 3>&,
                                        const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&);
template void interpolate<HatKernel>(const tree::Tree<3>&, const std::array<std::span<const double>, 3>&,
                                     const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&);
template void interpolate<Peskin4Kernel>(const tree::Tree<3>&, const std::array<std::span<const double>, 3>&,
                                         const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&);

template void interpolate_faces<DivergenceFree<CosineKernel>>(const tree::Tree<3>&, const fluid::FaceField<3>&,
    const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces<DivergenceFree<HatKernel>>(const tree::Tree<3>&, const fluid::FaceField<3>&,
    const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&, const NodeBoxes*, const WallWeights*);
template void interpolate_faces<DivergenceFree<Peskin4Kernel>>(const tree::Tree<3>&, const fluid::FaceField<3>&,
    const Eigen::Matrix3Xd&, Eigen::Matrix3Xd&, const NodeBoxes*, const WallWeights*);

}  // namespace capsflow::ibm
