// Spreading point forces onto the max-level cells or faces (operators and parallel scheme:
// spread.hpp).
#include "ibm/spread.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

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

// The stencil of node x: on cell centres (face_axis = -1) or on the faces normal to
// face_axis.
template <Kernel K>
BoxStencil stencil_of(const tree::TreeOptions<3>& o, double h, const double* x, int face_axis) {
  if (face_axis >= 0) return face_stencil<K>(o, h, x, face_axis);
  if constexpr (kIsDivergenceFree<K>) {
    throw std::invalid_argument("ibm: a divergence-free kernel exists only on faces");
  } else {
    const auto st = node_stencil<K>(o, h, x);
    BoxStencil b;
    for (int d = 0; d < 3; ++d) set_axis(b, d, st[d]);
    return b;
  }
}

// Adds the force components [c0, c1) of every node, through the stencils on cell centres
// (face_axis = -1) or on the faces normal to face_axis, to f[c0..c1).
template <Kernel K>
void spread_pass(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces, CellVector& f,
                 SpreadWorkspace& ws, int face_axis, int c0, int c1, const OwnedPositions& own,
                 const NodeBoxes* boxes = nullptr, const WallWeights* walls = nullptr) {
  const Eigen::Index n = x.cols();
  CAPSFLOW_ASSERT(!boxes || boxes->nodes() == n, "ibm: spreading with the boxes of other nodes");
  const int level = t.max_level();
  const double h = t.cell_size(level), inv_volume = 1.0 / (h * h * h);
  const auto& options = t.options();
  // Every node's stencil has the same widths (those of the kernel and the axis).
  const std::array<int, 3> widths = n > 0 ? stencil_of<K>(options, h, &x(0, 0), face_axis).n : std::array{1, 1, 1};
  const int cells_per_node = widths[0] * widths[1] * widths[2];
  const int weights_per_node = widths[0] + widths[1] + widths[2];
  ws.cells.resize(static_cast<std::size_t>(n) * cells_per_node);
  ws.weights.resize(static_cast<std::size_t>(n) * weights_per_node);
  ws.lowest.resize(static_cast<std::size_t>(n));
  ws.highest.resize(static_cast<std::size_t>(n));
  const Index level_begin = t.level(level).active_begin(), level_end = t.level(level).active_end();
  std::array<double*, 3> out{f[0].data(), f[1].data(), f[2].data()};
  Eigen::Index bad = n;  // the lowest node with a missing stencil cell

#pragma omp parallel if (n >= kParallelNodes)
  {
#pragma omp for schedule(static) reduction(min : bad)
    for (Eigen::Index i = 0; i < n; ++i) {
      const BoxStencil st = stencil_of<K>(options, h, &x(0, i), face_axis);
      CAPSFLOW_ASSERT(st.n == widths, "ibm: stencils of one kernel and axis differ in width");
      double* w = ws.weights.data() + i * weights_per_node;
      std::copy_n(st.w[0].begin(), widths[0], w);
      std::copy_n(st.w[1].begin(), widths[1], w + widths[0]);
      std::copy_n(st.w[2].begin(), widths[2], w + widths[0] + widths[1]);
      Index* c = ws.cells.data() + i * cells_per_node;
      ws.lowest[i] = 1;  // an empty range: no thread reads this node
      ws.highest[i] = 0;
      if (!(boxes && boxes->stencil_cells(i, st, c)) && find_owned_box(t, level, st.first, widths, own, c) >= 0) {
        bad = std::min(bad, i);
        continue;
      }
      // The node's range of cells, in locals (stores through ws inside the loop kept the
      // compiler from holding them in registers: a third of the pass).
      Index lowest = std::numeric_limits<Index>::max(), highest = -1;
      for (int s = 0; s < cells_per_node; ++s) {  // kNone: another rank's cell
        if (c[s] == tree::kNone) continue;
        lowest = std::min(lowest, c[s]);
        highest = std::max(highest, c[s]);
      }
      if (highest >= 0) {
        ws.lowest[i] = lowest;
        ws.highest[i] = highest;
      }
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
        const double* wx = ws.weights.data() + i * weights_per_node;
        const double* wy = wx + widths[0];
        const double* wz = wy + widths[1];
        const Index* c = ws.cells.data() + i * cells_per_node;
        // Next to an embedded wall: the open faces only, renormalised (wall_weights.hpp).
        const double* open = walls && face_axis >= 0 ? walls->open(i, face_axis) : nullptr;
        const double inverse_sum = open ? walls->inverse_sum(i, face_axis) : 1.0;
        for (int kz = 0, s = 0; kz < widths[2]; ++kz)
          for (int jy = 0; jy < widths[1]; ++jy) {
            const double wyz = wz[kz] * wy[jy];
            for (int ix = 0; ix < widths[0]; ++ix, ++s) {
              const Index cell = c[s];
              if (cell < own_lo || cell >= own_hi) continue;
              double wc = wyz * wx[ix];
              if (open) wc *= spread_factor(open[s], inverse_sum);
              for (int k = c0; k < c1; ++k) out[k][cell] += g[k] * wc;
            }
          }
      }
    }
  }
  if (bad < n) {  // rebuild the failing node's stencil serially for the message
    const BoxStencil st = stencil_of<K>(options, h, &x(0, bad), face_axis);
    std::vector<Index> c(static_cast<std::size_t>(cells_per_node));
    require_box(t, level, st.first, st.n, c.data(), bad, &x(0, bad), face_axis < 0 ? "spreading" : "face spreading",
                K::kName, own);
  }
}

}  // namespace

template <Kernel K>
void spread(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces, CellVector& f,
            SpreadWorkspace& ws, SpreadMode mode, const OwnedPositions& own) {
  prepare(t, x.cols(), forces, f, mode);
  spread_pass<K>(t, x, forces, f, ws, -1, 0, 3, own);
}

template <Kernel K>
void spread_faces(const tree::Tree<3>& t, const Eigen::Matrix3Xd& x, const Eigen::Matrix3Xd& forces,
                  fluid::FaceField<3>& f, SpreadWorkspace& ws, SpreadMode mode, const OwnedPositions& own,
                  const NodeBoxes* boxes, const WallWeights* walls) {
  CAPSFLOW_ASSERT(!walls || walls->near_nodes() == 0 || walls->nodes() == x.cols(),
                  "ibm: spreading with the wall weights of other nodes");
  prepare(t, x.cols(), forces, f, mode);
  for (int d = 0; d < 3; ++d) spread_pass<K>(t, x, forces, f, ws, d, d, d + 1, own, boxes, walls);
}

template void spread<CosineKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                   CellVector&, SpreadWorkspace&, SpreadMode, const OwnedPositions&);
template void spread<HatKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                CellVector&, SpreadWorkspace&, SpreadMode, const OwnedPositions&);
template void spread<Peskin4Kernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                    CellVector&, SpreadWorkspace&, SpreadMode, const OwnedPositions&);
template void spread_faces<CosineKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                         fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode, const OwnedPositions&, const NodeBoxes*, const WallWeights*);
template void spread_faces<HatKernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                      fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode, const OwnedPositions&, const NodeBoxes*, const WallWeights*);
template void spread_faces<Peskin4Kernel>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
                                          fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode, const OwnedPositions&, const NodeBoxes*, const WallWeights*);

template void spread_faces<DivergenceFree<CosineKernel>>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
    fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode, const OwnedPositions&, const NodeBoxes*, const WallWeights*);
template void spread_faces<DivergenceFree<HatKernel>>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
    fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode, const OwnedPositions&, const NodeBoxes*, const WallWeights*);
template void spread_faces<DivergenceFree<Peskin4Kernel>>(const tree::Tree<3>&, const Eigen::Matrix3Xd&, const Eigen::Matrix3Xd&,
    fluid::FaceField<3>&, SpreadWorkspace&, SpreadMode, const OwnedPositions&, const NodeBoxes*, const WallWeights*);

}  // namespace capsflow::ibm
