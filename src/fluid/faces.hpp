#pragma once
// Face fields on the tree (MAC velocities, face accelerations, face gradients).
//
// Convention: a face field is D cell-indexed arrays; uf[d][c] is the value on the LOWER
// face of cell c along d. The upper face of a leaf c is then uf[d][n] with n its +d
// neighbour, whatever n is: an active cell, a halo cell (the fine face at a jump to a
// coarser region) or a boundary cell (the wall face). So every face of every leaf has one slot.
//
// Which faces are computed: the fine side of every face. A leaf computes its lower faces,
// except where its lower neighbour is a parent (that face is coarse), and its upper faces
// where the upper neighbour is a halo cell or a boundary cell (nobody else owns them). Coarse faces
// (between a leaf and a parent of its level) then get the mean of the 2^(D-1) fine faces
// covering them (restrict_faces): what crosses the fine faces crosses the coarse one, so
// the divergence of a face field sums to the boundary flux exactly.
#include <array>
#include <span>
#include <vector>

#include "common/assert.hpp"
#include "tree/tree.hpp"

namespace capsflow::fluid {

using tree::Index;

template <int D>
using FaceField = std::array<std::vector<double>, D>;

// Whether every component has one slot per cell of t (a face field kept across an adapt
// must be resized with it).
template <int D>
bool spans_cells(const FaceField<D>& f, const tree::Tree<D>& t) {
  for (const auto& v : f)
    if (v.size() != static_cast<std::size_t>(t.num_cells())) return false;
  return true;
}

template <int D>
void resize(FaceField<D>& f, const tree::Tree<D>& t) {
  for (auto& v : f) v.assign(t.num_cells(), 0.0);
}

// The D components as spans, to exchange them together (Tree::exchange_all).
template <int D>
std::array<std::span<double>, D> components(FaceField<D>& f) {
  std::array<std::span<double>, D> out;
  for (int d = 0; d < D; ++d) out[d] = f[d];
  return out;
}

namespace detail {

// The faces for_each_face calls f for at leaf c. A function with the level's scalars as
// arguments, not a lambda capturing them: the OpenMP loops then hold them in registers (a
// lambda object shared with the loop is read through a pointer, and its h was reloaded after
// every store of f: 2% more instructions on one rank).
template <int D, class F>
inline void faces_of_leaf(const tree::Level<D>& lv, Index c, double h, Index active_end, Index halo_begin, F& f) {
  const Index* row = lv.face_row(c);
  for (int d = 0; d < D; ++d) {
    const Index lo = row[2 * d], hi = row[2 * d + 1];
    if (!(lo < active_end && !lv.is_leaf(lo))) f(d, lo, c, h, lv);
    if (hi >= halo_begin) f(d, c, hi, h, lv);
  }
}

}  // namespace detail

// Calls f(d, lower, upper, h, level) for every fine face: lower and upper are the
// same-level cells on either side along d, h their size; the face's slot is `upper`.
// Parallel over leaves. On N ranks, the faces that owned cells' stencils read: the loop
// visits the owned groups and Tree::face_ghosts (the ghosts whose slots an owned leaf, an
// owned parent's restriction or the advection's upwind terms read). The other ghosts' and
// the placeholders' faces are read by other ghosts only, whose values come from their
// owners by the exchanges.
template <int D, class F>
void for_each_face(const tree::Tree<D>& t, F&& f) {
  const bool distributed = t.distributed();
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double h = t.cell_size(l);
    const Index base = lv.base, active_end = lv.active_end(), halo_begin = lv.halo_begin();
    const auto [begin, end] = t.owned_range(l);  // the whole level on one rank
#pragma omp parallel for schedule(static) if (end - begin > tree::kParallelMin)
    for (Index i = begin; i < end; ++i)
      if (lv.leaf[i] && (!distributed || t.holds(base + i))) detail::faces_of_leaf<D>(lv, base + i, h, active_end, halo_begin, f);
    if (!distributed) continue;
    const std::span<const Index> ghosts = t.face_ghosts(l);
    const auto n = static_cast<Index>(ghosts.size());
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
    for (Index k = 0; k < n; ++k)
      detail::faces_of_leaf<D>(lv, ghosts[static_cast<std::size_t>(k)], h, active_end, halo_begin, f);
  }
}

namespace detail {

// The coarse faces of leaf c (next to a finer region) from their fine faces (restrict_faces).
// With `weights` (a face field), the weighted mean: sum w_f u_f / sum w_f, 0 where the
// weights are (embedded walls: the flux through the fluid part of a coarse face is then the
// sum of its fine faces').
template <int D>
inline void restrict_faces_at(const tree::Level<D>& lv, Index c, FaceField<D>& uf, const FaceField<D>* weights = nullptr) {
  constexpr int C = tree::kChildren<D>;
  // The mean of the lower faces along d of the children of `cell` (halo or active).
  auto lower_faces_mean = [&uf, &lv, weights](int d, Index cell) {
    const Index first = lv.first_child[static_cast<std::size_t>(cell - lv.base)];
    double sum = 0.0, weight = 0.0;
    for (int b = 0; b < C; ++b) {
      if (tree::child_bit(b, d)) continue;
      if (weights) {
        const double w = (*weights)[d][first + b];
        sum += w * uf[d][first + b];
        weight += w;
      } else {
        sum += uf[d][first + b];
      }
    }
    if (weights) return weight > 0.0 ? sum / weight : 0.0;
    return sum / (C / 2);
  };
  const Index* row = lv.face_row(c);
  for (int d = 0; d < D; ++d) {
    const Index lo = row[2 * d], hi = row[2 * d + 1];
    if (lo < lv.active_end() && !lv.is_leaf(lo)) uf[d][c] = lower_faces_mean(d, c);     // c's halo children's
    if (hi < lv.active_end() && !lv.is_leaf(hi)) uf[d][hi] = lower_faces_mean(d, hi);  // hi's children's
  }
}

}  // namespace detail

// Coarse faces (leaf against a parent of its level) get the mean of their fine faces, weighted
// by `weights` when given (restrict_faces_at).
template <int D>
void restrict_faces(const tree::Tree<D>& t, FaceField<D>& uf, const FaceField<D>* weights = nullptr) {
  CAPSFLOW_ASSERT(spans_cells<D>(uf, t), "restrict_faces: the face field does not have the tree's num_cells slots");
  // Distributed: the owned groups and Tree::face_ghosts, as for_each_face (an owned parent's
  // slot is restricted by its lower neighbour leaf, which can be a ghost).
  const bool distributed = t.distributed();
  for (int l = 0; l < t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const Index base = lv.base;
    const auto [begin, end] = t.owned_range(l);  // the whole level on one rank
#pragma omp parallel for schedule(static) if (end - begin > tree::kParallelMin)
    for (Index i = begin; i < end; ++i)
      if (lv.leaf[i] == tree::Level<D>::kLeafNextToFiner && (!distributed || t.holds(base + i)))
        detail::restrict_faces_at<D>(lv, base + i, uf, weights);
    if (!distributed) continue;
    const std::span<const Index> ghosts = t.face_ghosts(l);
    const auto n = static_cast<Index>(ghosts.size());
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
    for (Index k = 0; k < n; ++k) {
      const Index c = ghosts[static_cast<std::size_t>(k)];
      if (lv.leaf[static_cast<std::size_t>(c - base)] == tree::Level<D>::kLeafNextToFiner) detail::restrict_faces_at<D>(lv, c, uf, weights);
    }
  }
}

// Calls f(c, l, h) for every leaf with its level and size. Parallel.
template <int D, class F>
void for_each_leaf_level(const tree::Tree<D>& t, F&& f) {
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double h = t.cell_size(l);
    const Index n = lv.n_active, base = lv.base;
#pragma omp parallel for schedule(static) if (n > tree::kParallelMin)
    for (Index i = 0; i < n; ++i)
      if (lv.leaf[i]) f(base + i, l, h);
  }
}

// As for_each_leaf_level, on the sibling groups holding this rank's cells only (every leaf
// on one rank; tree::Tree::owned_groups): for loops whose values on the ghosts are
// exchanged before anything reads them.
template <int D, class F>
void for_each_owned_leaf_level(const tree::Tree<D>& t, F&& f) {
  for (int l = 0; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    const double h = t.cell_size(l);
    const auto [begin, end] = t.owned_range(l);
    const Index base = lv.base;
#pragma omp parallel for schedule(static) if (end - begin > tree::kParallelMin)
    for (Index i = begin; i < end; ++i)
      if (lv.leaf[i]) f(base + i, l, h);
  }
}

// Halo cells take their coarse leaf's value (for slopes: the coarse cell's slope).
template <int D>
void inject_halo(const tree::Tree<D>& t, std::span<double> v) {
  constexpr int C = tree::kChildren<D>;
  for (int l = 1; l <= t.depth(); ++l) {
    const tree::Level<D>& lv = t.level(l);
    for (Index g = 0; g < lv.n_halo / C; ++g)
      for (int b = 0; b < C; ++b) v[lv.halo_begin() + g * C + b] = v[lv.halo_parent[g]];
  }
}

// Upper-face slot of leaf c of level l along d.
template <int D>
Index upper_face(const tree::Level<D>& lv, Index c, int d) {
  return lv.face_row(c)[2 * d + 1];
}

// div(uf) at the leaves this rank owns (every leaf on one rank; the callers read owned
// leaves only): sum_d (uf_up - uf_low) / h. With `open` (embedded walls: the faces' fluid
// fractions), the divergence of each cell's fluid part per unit of its whole volume,
// sum_d (fs_up uf_up - fs_low uf_low) / h.
template <int D>
void divergence(const tree::Tree<D>& t, const FaceField<D>& uf, std::span<double> div, const FaceField<D>* open = nullptr) {
  CAPSFLOW_ASSERT(spans_cells<D>(uf, t) && div.size() == static_cast<std::size_t>(t.num_cells()),
                  "divergence: a field does not have the tree's num_cells slots");
  if (open) {  // two loops: the brick's own pays no branch per cell
    for_each_owned_leaf_level<D>(t, [&](Index c, int l, double h) {
      const Index* row = t.level(l).face_row(c);
      double s = 0.0;
      for (int d = 0; d < D; ++d) s += (*open)[d][row[2 * d + 1]] * uf[d][row[2 * d + 1]] - (*open)[d][c] * uf[d][c];
      div[c] = s / h;
    });
    return;
  }
  for_each_owned_leaf_level<D>(t, [&](Index c, int l, double h) {
    const Index* row = t.level(l).face_row(c);
    double s = 0.0;
    for (int d = 0; d < D; ++d) s += uf[d][row[2 * d + 1]] - uf[d][c];
    div[c] = s / h;
  });
}

}  // namespace capsflow::fluid
