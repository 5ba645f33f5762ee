// Spreading point forces onto the max-level cells or faces (operators and parallel scheme:
// spread.hpp).
#include "ibm/spread.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>

#include <fmt/format.h>

#include "ibm/stencil.hpp"

namespace capsflow::ibm {

namespace {
// Below this many nodes a parallel region costs more than the work.
constexpr Eigen::Index kParallelNodes = 256;

void prepare(const tree::Tree<3>& t, Eigen::Index nodes, const Eigen::Matrix3Xd& forces, CellVector& f,
             SpreadMode mode) {
  if (forces.cols() != nodes)
    throw std::invalid_argument(fmt::format("ibm: spread got {} forces for {} nodes", forces.cols(), nodes));
  const auto cells = static_cast<std::size_t>(t.num_cells());
  for (auto& fd : f) {
    if (mode == SpreadMode::assign) fd.assign(cells, 0.0);
    else if (fd.size() != cells)
      throw std::invalid_argument(fmt::format("ibm: spread (add) into a field of {} cells, the tree has {}",
                                              fd.size(), cells));
  }
}

// Adds the force components [c0, c1) of every node, through the stencils on cell centres
// (face_axis = -1) or on the faces normal to face_axis, to f[c0..c1).
template <Kernel K>
void spread_pass(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces, CellVector& f,
                 SpreadWorkspace& ws, int face_axis, int c0, int c1) {
  constexpr int W = K::kSupport, W3 = W * W * W;
  const Eigen::Index n = x.cols();
  const int level = t.max_level();
  const double h = t.cell_size(level), inv_volume = 1.0 / (h * h * h);
  const auto& options = t.options();
  ws.cells.resize(static_cast<std::size_t>(n) * W3);
  ws.weights.resize(static_cast<std::size_t>(n) * 3 * W);
  ws.lowest.resize(static_cast<std::size_t>(n));
  ws.highest.resize(static_cast<std::size_t>(n));
  const Index level_begin = t.level(level).active_begin(), level_end = t.level(level).active_end();
  std::array<double*, 3> out{f[0].data(), f[1].data(), f[2].data()};
  Eigen::Index bad = n;  // the lowest node with a missing stencil cell

#pragma omp parallel if (n >= kParallelNodes)
  {
#pragma omp for schedule(static) reduction(min : bad)
    for (Eigen::Index i = 0; i < n; ++i) {
      const auto st = node_stencil<K>(options, h, &x(0, i), face_axis);
      double* w = ws.weights.data() + i * 3 * W;
      for (int d = 0; d < 3; ++d) std::copy(st[d].w.begin(), st[d].w.end(), w + d * W);
      Index* c = ws.cells.data() + i * W3;
      if (find_patch<W>(t, level, {st[0].first, st[1].first, st[2].first}, c) >= 0) {
        bad = std::min(bad, i);
        ws.lowest[i] = 1;  // an empty range: no thread reads this node
        ws.highest[i] = 0;
        continue;
      }
      const auto [lo, hi] = std::minmax_element(c, c + W3);
      ws.lowest[i] = *lo;
      ws.highest[i] = *hi;
    }
    // (implicit barrier: the stencils are complete, bad is reduced)
    if (bad == n) {
      const std::int64_t span = level_end - level_begin;
      const int threads = omp_get_num_threads(), me = omp_get_thread_num();
      const auto own_lo = static_cast<Index>(level_begin + span * me / threads);
      const auto own_hi = static_cast<Index>(level_begin + span * (me + 1) / threads);
      for (Eigen::Index i = 0; i < n; ++i) {
        if (ws.highest[i] < own_lo || ws.lowest[i] >= own_hi) continue;
        double g[3];
        for (int k = c0; k < c1; ++k) g[k] = forces(k, i) * inv_volume;
        const double* w = ws.weights.data() + i * 3 * W;
        const Index* c = ws.cells.data() + i * W3;
        for (int kz = 0, s = 0; kz < W; ++kz)
          for (int jy = 0; jy < W; ++jy) {
            const double wyz = w[2 * W + kz] * w[W + jy];
            for (int ix = 0; ix < W; ++ix, ++s) {
              const Index cell = c[s];
              if (cell < own_lo || cell >= own_hi) continue;
              const double wc = wyz * w[ix];
              for (int k = c0; k < c1; ++k) out[k][cell] += g[k] * wc;
            }
          }
      }
    }
  }
  if (bad < n) {  // rebuild the failing node's stencil serially for the message
    const auto st = node_stencil<K>(options, h, &x(0, bad), face_axis);
    Index c[W3];
    require_patch<W>(t, level, {st[0].first, st[1].first, st[2].first}, c, bad, &x(0, bad),
                     face_axis < 0 ? "spreading" : "face spreading", K::kName);
  }
}

}  // namespace

template <Kernel K>
void spread(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces, CellVector& f,
            SpreadWorkspace& ws, SpreadMode mode) {
  prepare(t, x.cols(), forces, f, mode);
  spread_pass<K>(t, x, forces, f, ws, -1, 0, 3);
}

template <Kernel K>
void spread_faces(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces,
                  fluid::FaceField<3>& f, SpreadWorkspace& ws, SpreadMode mode) {
  prepare(t, x.cols(), forces, f, mode);
  for (int d = 0; d < 3; ++d) spread_pass<K>(t, x, forces, f, ws, d, d, d + 1);
}

template void spread<CosineKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                   CellVector&, SpreadWorkspace&, SpreadMode);
template void spread<HatKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                CellVector&, SpreadWorkspace&, SpreadMode);
template void spread<Peskin4Kernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                    CellVector&, SpreadWorkspace&, SpreadMode);
template void spread_faces<CosineKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                         fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode);
template void spread_faces<HatKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                      fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode);
template void spread_faces<Peskin4Kernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                          fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode);

}  // namespace capsflow::ibm
