// A step's stencil boxes around the membrane nodes (node_boxes.hpp).
#include "ibm/node_boxes.hpp"

#include <algorithm>
#include <limits>

#include "tree/distributed_forest.hpp"
#include "tree/partition.hpp"

namespace capsflow::ibm {

NodeBox node_box(const tree::TreeOptions<3>& o, double h, const double* x, std::span<const KernelKind> kinds,
                 bool divergence_free) {
  tree::Coords<3> lo{}, hi{};
  lo.fill(std::numeric_limits<std::int32_t>::max());
  hi.fill(std::numeric_limits<std::int32_t>::min());
  for (const KernelKind kind : kinds)
    with_face_kernel(kind, divergence_free, [&]<Kernel K>(K) {
      for (int axis = 0; axis < 3; ++axis) {
        const BoxStencil st = face_stencil_bounds<K>(o, h, x, axis);
        for (int d = 0; d < 3; ++d) {
          lo[d] = std::min(lo[d], st.first[d]);
          hi[d] = std::max(hi[d], st.first[d] + st.n[d]);
        }
      }
    });
  NodeBox b{.first = lo, .widths = {}};
  for (int d = 0; d < 3; ++d) b.widths[d] = hi[d] - lo[d];
  return b;
}

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
  interpolator_.assign(static_cast<std::size_t>(n), Interpolator::parts);
  held_complete_.assign(static_cast<std::size_t>(n), 0);
  held_in_owned_.assign(static_cast<std::size_t>(n), 0);
  if (!own.all()) held_cells_.resize(cells_.size());
#pragma omp parallel for schedule(static) if (n >= 256)
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto [lo, w] = node_box(o, h, x.col(i).data(), kinds, divergence_free);
    const auto u = static_cast<std::size_t>(i);
    CAPSFLOW_ASSERT(w[0] <= widest && w[1] <= widest && w[2] <= widest, "ibm: a node's stencils span more than its box");
    first_[u] = lo;
    widths_[u] = w;
    Index* owned = cells_.data() + u * static_cast<std::size_t>(stride_);
    if (own.all()) {
      complete_[u] = find_box(t, level, lo, w, owned) < 0;
      continue;
    }
    // The box's centre cell and its owner, the node's one interpolator (every rank decides
    // alike from the node's position and the partition).
    tree::Coords<3> centre{};
    bool inside = true;
    for (int d = 0; d < 3; ++d) {
      inside = inside && w[d] / 2 <= tree::kGhostWidth && w[d] - 1 - w[d] / 2 <= tree::kGhostWidth;
      const auto extent = static_cast<std::int32_t>(o.roots[d] << level);
      centre[d] = lo[d] + w[d] / 2;
      if (centre[d] < 0 || centre[d] >= extent) {
        if (!o.periodic[d]) inside = false;
        centre[d] = ((centre[d] % extent) + extent) % extent;
      }
    }
    if (inside)
      interpolator_[u] = own.contains(tree::curve_position<3>(level, tree::morton_encode<3>(centre), o.max_level))
                             ? Interpolator::here
                             : Interpolator::elsewhere;
    // One search of the local tree. Where the whole box is here (owned cells and ghosts), the
    // owned box is its owned cells (find_owned_box's rule): all of them when the box's lowest
    // and highest curve positions are this rank's (Morton keys grow with each coordinate, so
    // the box lies between them), else by each cell's role. Else the owned cells one by one.
    if (find_box(t, level, lo, w, owned) < 0) {
      complete_[u] = 1;
      held_complete_[u] = interpolator_[u] == Interpolator::here;
      tree::Coords<3> top{};
      bool wraps = false;
      for (int d = 0; d < 3; ++d) {
        top[d] = lo[d] + w[d] - 1;
        wraps = wraps || lo[d] < 0 || top[d] >= static_cast<std::int32_t>(o.roots[d] << level);
      }
      const auto position = [&](const tree::Coords<3>& c) {
        return tree::curve_position<3>(level, tree::morton_encode<3>(c), o.max_level);
      };
      held_in_owned_[u] = !wraps && own.contains(position(lo)) && own.contains(position(top));
      if (held_in_owned_[u]) continue;
      const int size = w[0] * w[1] * w[2];
      if (held_complete_[u])
        std::copy(owned, owned + size, held_cells_.data() + u * static_cast<std::size_t>(stride_));
      for (int k = 0; k < size; ++k)
        if (!t.owns(owned[k])) owned[k] = tree::kNone;
    } else {
      complete_[u] = find_owned_box(t, level, lo, w, own, owned) < 0;
    }
  }
}

void NodeBoxes::copy_stencil(const Index* box, const tree::Coords<3>& lo, const std::array<int, 3>& w,
                             const BoxStencil& st, Index* cells) {
  int offset[3];
  for (int d = 0; d < 3; ++d) {
    offset[d] = st.first[d] - lo[d];
    CAPSFLOW_ASSERT(offset[d] >= 0 && offset[d] + st.n[d] <= w[d], "ibm: a stencil outside its node's box");
  }
  for (int kz = 0, s = 0; kz < st.n[2]; ++kz)
    for (int jy = 0; jy < st.n[1]; ++jy) {
      const Index* row = box + ((kz + offset[2]) * w[1] + jy + offset[1]) * w[0] + offset[0];
      for (int ix = 0; ix < st.n[0]; ++ix, ++s) cells[s] = row[ix];
    }
}

bool NodeBoxes::held_stencil_cells(Eigen::Index i, const BoxStencil& st, Index* cells) const {
  const auto u = static_cast<std::size_t>(i);
  CAPSFLOW_ASSERT(u < held_complete_.size(), "ibm: NodeBoxes asked for a node it has no box of");
  if (interpolator_[u] != Interpolator::here || !held_complete_[u]) return false;
  const std::vector<Index>& box = held_in_owned_[u] ? cells_ : held_cells_;
  copy_stencil(box.data() + u * static_cast<std::size_t>(stride_), first_[u], widths_[u], st, cells);
  if constexpr (kAssertions)
    CAPSFLOW_ASSERT(box_is_the_stencil(*tree_, tree_->max_level(), st.first, st.n, cells),
                    "ibm: a node's box is not the tree's cells there (stale boxes)");
  return true;
}

bool NodeBoxes::stencil_cells(Eigen::Index i, const BoxStencil& st, Index* cells) const {
  const auto u = static_cast<std::size_t>(i);
  CAPSFLOW_ASSERT(u < complete_.size(), "ibm: NodeBoxes asked for a node it has no box of");
  if (!complete_[u]) return false;
  copy_stencil(cells_.data() + u * static_cast<std::size_t>(stride_), first_[u], widths_[u], st, cells);
  if constexpr (kAssertions) {
    const bool whole = std::none_of(cells, cells + st.size(), [](Index c) { return c == tree::kNone; });
    CAPSFLOW_ASSERT(!whole || box_is_the_stencil(*tree_, tree_->max_level(), st.first, st.n, cells),
                    "ibm: a node's box is not the tree's cells there (stale boxes)");
  }
  return true;
}

void NodeBoxes::clear() {
  interpolator_.clear();
  held_complete_.clear();
  held_in_owned_.clear();
  first_.clear();
  widths_.clear();
  complete_.clear();
  tree_ = nullptr;
}

}  // namespace capsflow::ibm
