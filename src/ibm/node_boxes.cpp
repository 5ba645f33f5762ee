// A step's stencil boxes around the membrane nodes (node_boxes.hpp).
#include "ibm/node_boxes.hpp"

#include <algorithm>
#include <limits>

namespace capsflow::ibm {

void NodeBoxes::find(const tree::Tree<3>& t, Eigen::Ref<const Eigen::Matrix3Xd> x, std::span<const KernelKind> kinds,
                     bool divergence_free, const OwnedPositions& own) {
  const Eigen::Index n = x.cols();
  const int level = t.max_level();
  const double h = t.cell_size(level);
  const auto& o = t.options();
  int widest = 0;  // per axis, over kernels: the union of a node's stencils is at most one wider
  for (const KernelKind kind : kinds) widest = std::max(widest, support_of(kind, false) + 1);
  CAPSFLOW_ASSERT(widest <= kMaxBoxWidth, "ibm: a node's box is wider than kMaxBoxWidth");
  stride_ = widest * widest * widest;
  first_.resize(static_cast<std::size_t>(n));
  widths_.resize(static_cast<std::size_t>(n));
  complete_.assign(static_cast<std::size_t>(n), 0);
  cells_.resize(static_cast<std::size_t>(n) * static_cast<std::size_t>(stride_));
  tree_ = &t;
#pragma omp parallel for schedule(static) if (n >= 256)
  for (Eigen::Index i = 0; i < n; ++i) {
    tree::Coords<3> lo{}, hi{};
    lo.fill(std::numeric_limits<std::int32_t>::max());
    hi.fill(std::numeric_limits<std::int32_t>::min());
    for (const KernelKind kind : kinds)
      with_face_kernel(kind, divergence_free, [&]<Kernel K>(K) {
        for (int axis = 0; axis < 3; ++axis) {
          const BoxStencil st = face_stencil_bounds<K>(o, h, x.col(i).data(), axis);
          for (int d = 0; d < 3; ++d) {
            lo[d] = std::min(lo[d], st.first[d]);
            hi[d] = std::max(hi[d], st.first[d] + st.n[d]);
          }
        }
      });
    const auto u = static_cast<std::size_t>(i);
    std::array<int, 3> w{};
    for (int d = 0; d < 3; ++d) w[d] = hi[d] - lo[d];
    CAPSFLOW_ASSERT(w[0] <= widest && w[1] <= widest && w[2] <= widest, "ibm: a node's stencils span more than its box");
    first_[u] = lo;
    widths_[u] = w;
    complete_[u] = find_owned_box(t, level, lo, w, own, cells_.data() + u * static_cast<std::size_t>(stride_)) < 0;
  }
}

bool NodeBoxes::stencil_cells(Eigen::Index i, const BoxStencil& st, Index* cells) const {
  const auto u = static_cast<std::size_t>(i);
  CAPSFLOW_ASSERT(u < complete_.size(), "ibm: NodeBoxes asked for a node it has no box of");
  if (!complete_[u]) return false;
  const tree::Coords<3>& lo = first_[u];
  const std::array<int, 3>& w = widths_[u];
  int offset[3];
  for (int d = 0; d < 3; ++d) {
    offset[d] = st.first[d] - lo[d];
    CAPSFLOW_ASSERT(offset[d] >= 0 && offset[d] + st.n[d] <= w[d], "ibm: a stencil outside its node's box");
  }
  const Index* box = cells_.data() + u * static_cast<std::size_t>(stride_);
  for (int kz = 0, s = 0; kz < st.n[2]; ++kz)
    for (int jy = 0; jy < st.n[1]; ++jy) {
      const Index* row = box + ((kz + offset[2]) * w[1] + jy + offset[1]) * w[0] + offset[0];
      for (int ix = 0; ix < st.n[0]; ++ix, ++s) cells[s] = row[ix];
    }
  if constexpr (kAssertions) {
    const bool whole = std::none_of(cells, cells + st.size(), [](Index c) { return c == tree::kNone; });
    CAPSFLOW_ASSERT(!whole || box_is_the_stencil(*tree_, tree_->max_level(), st.first, st.n, cells),
                    "ibm: a node's box is not the tree's cells there (stale boxes)");
  }
  return true;
}

void NodeBoxes::clear() {
  first_.clear();
  widths_.clear();
  complete_.clear();
  tree_ = nullptr;
}

}  // namespace capsflow::ibm
