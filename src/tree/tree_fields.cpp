// Field values outside the leaves (restriction, halo, boundary cells) and the transfer of fields
// to a new tree. One mechanism serves every solver: see the rules in prolongation.hpp
// (levels) and boundary.hpp (sides).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "tree/prolongation.hpp"
#include "tree/tree.hpp"

namespace capsflow::tree {

namespace {

template <int D>
ParentSlopes<D> slopes_of(const Level<D>& lv, Index parent, std::span<const double> v,
                          Prolongation p) {
  const Index* row = lv.face_row(parent);
  double lo[D], hi[D];
  for (int d = 0; d < D; ++d) {
    lo[d] = v[row[2 * d]];
    hi[d] = v[row[2 * d + 1]];
  }
  return p == Prolongation::limited ? ParentSlopes<D>::limited(v[parent], lo, hi)
                                    : ParentSlopes<D>::linear(v[parent], lo, hi);
}

// The parent's 3^D neighbourhood, indexed as quadratic_child expects.
template <int D>
void block_of(const Level<D>& lv, Index parent, std::span<const double> v, double* block) {
  static constexpr auto kCode = [] {  // block code of each stencil slot
    std::array<int, kStencil<D>> code{};
    for (int s = 0; s < kStencil<D>; ++s)
      for (int d = D - 1; d >= 0; --d) code[s] = code[s] * 3 + kOffsets<D>[s][d] + 1;
    return code;
  }();
  const std::size_t row = Level<D>::row_of(parent - lv.base);
  const Index* face = lv.face.data() + row * kFaces<D>;
  const Index* diag = lv.diag.data() + row * kDiagonals<D>;
  for (int s = 0; s < kFaces<D>; ++s) block[kCode[s]] = v[face[s]];
  for (int s = kFaces<D>; s < kStencil<D>; ++s) block[kCode[s]] = v[diag[s - kFaces<D>]];
  block[(ipow(3, D) - 1) / 2] = v[parent];
}

}  // namespace

template <int D>
FieldId Tree<D>::add_field(FieldSpec<D> spec) {
  for (const auto& f : fields_)
    if (f.name == spec.name)
      throw std::invalid_argument(fmt::format("tree: field '{}' is registered twice", spec.name));
  fields_.push_back(std::move(spec));
  data_.emplace_back(num_cells_, 0.0);
  data_scratch_.emplace_back();
  return static_cast<FieldId>(fields_.size() - 1);
}

template <int D>
void Tree<D>::restrict_level(int l, std::span<double> v) const {
  CAPSFLOW_ASSERT(v.size() == static_cast<std::size_t>(num_cells_), "Tree::restrict_level: the field does not have num_cells entries");
  constexpr int C = kChildren<D>;
  const Level<D>& lv = levels_[l];
  // Distributed: the parents this rank owns (restrict_and_exchange brings the ghosts').
  const auto [first, last] = owned_range(l);
  const Index b = lv.active_begin(), from = b + first, to = b + last;
#pragma omp parallel for schedule(static) if (to - from > kParallelMin)
  for (Index c = from; c < to; ++c) {
    if (lv.leaf[c - b]) continue;
    const Index fc = lv.first_child[c - b];
    double sum = 0.0;
    for (int k = 0; k < C; ++k) sum += v[fc + k];
    v[c] = sum * (1.0 / C);
  }
}

template <int D>
void Tree<D>::poison_dropped_halos(int l, std::span<double> v, HaloCells which) const {
  constexpr int C = kChildren<D>;
  const Level<D>& lv = levels_[l];
  std::vector<std::uint8_t> kept(static_cast<std::size_t>(lv.n_halo / C), 0);
  for (const Index g : held_halo_[static_cast<std::size_t>(which)][static_cast<std::size_t>(l)]) kept[static_cast<std::size_t>(g)] = 1;
  auto poison = [&](Index g) {
    if (kept[static_cast<std::size_t>(g)]) return;
    for (int k = 0; k < C; ++k) v[static_cast<std::size_t>(lv.halo_begin() + g * C + k)] = std::numeric_limits<double>::quiet_NaN();
  };
  if (which == HaloCells::all) {
    for (Index g = 0; g < lv.n_halo / C; ++g) poison(g);
  } else {
    for (const Index g : lv.halo_read) poison(g);
  }
}

template <int D>
void Tree<D>::fill_halo(int l, std::span<double> v, Prolongation p, HaloCells which, const InjectedHalos* injected) const {
  fill_halo_groups(l, v, p, which, injected, false);
}

template <int D>
void Tree<D>::fill_halo_groups(int l, std::span<double> v, Prolongation p, HaloCells which, const InjectedHalos* injected,
                               bool refill) const {
  CAPSFLOW_ASSERT(v.size() == static_cast<std::size_t>(num_cells_), "Tree::fill_halo: the field does not have num_cells entries");
  constexpr int C = kChildren<D>;
  if (l <= 0 || l > depth_) return;
  const Level<D>& lv = levels_[l];
  const Level<D>& coarse = levels_[l - 1];
  // One rank: every group, or Level::halo_read; N ranks: those whose values reach owned
  // cells (Tree::collect_held_halos).
  if constexpr (kAssertions)
    if (dist_ && !refill) poison_dropped_halos(l, v, which);
  const bool all = which == HaloCells::all && !dist_;
  const std::vector<Index>& list =
      dist_ ? held_halo_[static_cast<std::size_t>(which)][static_cast<std::size_t>(l)] : lv.halo_read;
  const Index groups = all ? lv.n_halo / C : static_cast<Index>(list.size());
  const Index* listed = list.data();
  const Index first = lv.halo_begin();
  const std::uint8_t* inject = nullptr;
  if (injected && which == HaloCells::face_read && static_cast<std::size_t>(l) < injected->size() &&
      !(*injected)[static_cast<std::size_t>(l)].empty()) {
    CAPSFLOW_ASSERT((*injected)[static_cast<std::size_t>(l)].size() == static_cast<std::size_t>(lv.n_halo / C),
                    "Tree::fill_halo: the injected halos were made for another tree");
    inject = (*injected)[static_cast<std::size_t>(l)].data();
  }
  if (refill && !inject) return;
  // Whether group g is not prolonged here: a flagged group is injected now, and a refill
  // prolongs the flagged groups alone.
  auto injected_now = [inject, refill, first, &lv, v](Index g) {
    const bool flagged = inject && inject[g];
    if (refill) return !flagged;
    if (flagged) std::fill_n(v.data() + first + g * C, C, v[lv.halo_parent[g]]);
    return flagged;
  };
  if (p == Prolongation::quadratic) {
#pragma omp parallel for schedule(static) if (groups * C > kParallelMin)
    for (Index i = 0; i < groups; ++i) {
      const Index g = all ? i : listed[i];
      if (injected_now(g)) continue;
      double block[ipow(3, D)];
      block_of<D>(coarse, lv.halo_parent[g], v, block);
      quadratic_children<D>(block, v.data() + first + g * C);
    }
    return;
  }
#pragma omp parallel for schedule(static) if (groups * C > kParallelMin)
  for (Index i = 0; i < groups; ++i) {
    const Index g = all ? i : listed[i];
    if (injected_now(g)) continue;
    const auto s = slopes_of<D>(coarse, lv.halo_parent[g], v, p);
    for (int k = 0; k < C; ++k) v[first + g * C + k] = s.child(k);
  }
}

template <int D>
InjectedHalos Tree<D>::injected_halos(std::span<const std::uint8_t> closed) const {
  CAPSFLOW_ASSERT(closed.size() == static_cast<std::size_t>(num_cells_), "Tree::injected_halos: the flags do not have num_cells entries");
  constexpr int C = kChildren<D>;
  InjectedHalos out(static_cast<std::size_t>(depth_ + 1));
  for (int l = 1; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    std::vector<std::uint8_t>& flags = out[static_cast<std::size_t>(l)];
    flags.resize(static_cast<std::size_t>(lv.n_halo / C));
    bool any = false;
    for (Index g = 0; g < lv.n_halo / C; ++g) {
      flags[static_cast<std::size_t>(g)] = closed[static_cast<std::size_t>(lv.halo_parent[g])] != 0;
      any = any || flags[static_cast<std::size_t>(g)];
    }
    if (!any) {
      flags.clear();  // nothing to inject on this level: fills and refills pass it by
      continue;
    }
    if (l == depth_) continue;
    // A prolongation to level l + 1 reads the 3^D block of its coarse cell (a boundary cell
    // stands for its source): those halo groups keep their prolonged values. Threads clear
    // flags concurrently (the same value), hence the atomic stores.
    auto keep_block = [&](Index parent) {
      for (int s = 0; s < kStencil<D>; ++s) {
        Index c = lv.neighbor(parent, s);
        while (c >= lv.boundary_begin() && c < lv.boundary_end()) c = lv.boundary_source[c - lv.boundary_begin()];
        if (c >= lv.halo_begin() && c < lv.halo_end())
          std::atomic_ref<std::uint8_t>(flags[static_cast<std::size_t>((c - lv.halo_begin()) / C)]).store(0, std::memory_order_relaxed);
      }
    };
    const Level<D>& next = levels_[l + 1];
    const Index active_groups = next.n_active / C, groups = active_groups + next.n_halo / C;
#pragma omp parallel for schedule(static) if (groups * C > kParallelMin)
    for (Index g = 0; g < groups; ++g) keep_block(g < active_groups ? next.group_parent[g] : next.halo_parent[g - active_groups]);
  }
  return out;
}

template <int D>
void Tree<D>::refill_injected_halos(std::span<double> v, const BoundaryConditions<D>& bc, Prolongation p,
                                    const InjectedHalos& injected) const {
  // Level by level as the sync: a level's boundary cells may stand for its halo cells
  // (a level without injected groups kept its own).
  for (int l = 1; l <= depth_; ++l) {
    if (static_cast<std::size_t>(l) >= injected.size() || injected[static_cast<std::size_t>(l)].empty()) continue;
    fill_halo_groups(l, v, p, HaloCells::face_read, &injected, true);
    fill_boundary_cells(l, v, bc);
  }
}

template <int D>
void Tree<D>::prolong_level(int l, std::span<double> v, Prolongation p) const {
  CAPSFLOW_ASSERT(v.size() == static_cast<std::size_t>(num_cells_), "Tree::prolong_level: the field does not have num_cells entries");
  constexpr int C = kChildren<D>;
  if (l <= 0 || l > depth_) return;
  const Level<D>& coarse = levels_[l - 1];
#pragma omp parallel for schedule(static) if (coarse.n_active > kParallelMin / C)
  for (Index i = 0; i < coarse.n_active; ++i) {
    if (coarse.leaf[i]) continue;
    const auto s = slopes_of<D>(coarse, coarse.base + i, v, p);
    const Index fc = coarse.first_child[i];
    for (int k = 0; k < C; ++k) v[fc + k] = s.child(k);
  }
}

template <int D>
void Tree<D>::poison_dropped_boundary_cells(int l, std::span<double> v) const {
  const Level<D>& lv = levels_[l];
  std::vector<std::uint8_t> kept(static_cast<std::size_t>(lv.n_boundary), 0);
  for (const Index g : held_boundary_fill_[static_cast<std::size_t>(l)]) kept[static_cast<std::size_t>(g - lv.boundary_begin())] = 1;
  for (const Index g : lv.boundary_fill)
    if (!kept[static_cast<std::size_t>(g - lv.boundary_begin())]) v[static_cast<std::size_t>(g)] = std::numeric_limits<double>::quiet_NaN();
}

template <int D>
void Tree<D>::fill_boundary_cells(int l, std::span<double> v, const BoundaryConditions<D>& bc) const {
  CAPSFLOW_ASSERT(v.size() == static_cast<std::size_t>(num_cells_), "Tree::fill_boundary_cells: the field does not have num_cells entries");
  const Level<D>& lv = levels_[l];
  if constexpr (kAssertions)
    if (dist_) poison_dropped_boundary_cells(l, v);
  // N ranks: the boundary cells whose source holds a real value (collect_held_boundary_fill).
  const std::vector<Index>& boundary_fill = dist_ ? held_boundary_fill_[static_cast<std::size_t>(l)] : lv.boundary_fill;
  const Index boundary_fill_faces = dist_ ? held_boundary_fill_faces_[static_cast<std::size_t>(l)] : lv.boundary_fill_faces;
  const double h = cell_size_[l];
  const Index g0 = lv.boundary_begin();
  bool constant = true;
  for (const auto& sc : bc.side) constant = constant && !sc.function;
  if (constant) {  // the common case (every multigrid correction): no point evaluation
    double mul[2 * D], add[2 * D];
    for (int s = 0; s < 2 * D; ++s) {
      const bool dirichlet = bc.side[s].kind == BcKind::dirichlet;
      mul[s] = dirichlet ? -1.0 : 1.0;
      add[s] = dirichlet ? 2.0 * bc.side[s].value : h * bc.side[s].value;
    }
    auto fill = [&](Index g) {
      const Index local = g - g0;
      const int side = lv.boundary_side[local];
      v[g] = add[side] + mul[side] * v[lv.boundary_source[local]];
    };
    // Boundary cells across a face read active or halo cells only, so they go in parallel (a
    // refined wall has many; the multigrid refills them after every sweep). Edges and corners
    // read those across a face: after them, in order.
    const Index faces = boundary_fill_faces, all = static_cast<Index>(boundary_fill.size());
#pragma omp parallel for schedule(static) if (faces > kParallelMin)
    for (Index i = 0; i < faces; ++i) fill(boundary_fill[i]);
    for (Index i = faces; i < all; ++i) fill(boundary_fill[i]);
    return;
  }
  for (const Index g : boundary_fill) {
    const Index local = g - g0;
    const int side = lv.boundary_side[local];
    const SideCondition<D>& sc = bc.side[side];
    double value = sc.value;
    if (sc.function) {
      // The boundary point between the boundary cell and its source.
      Point<D> x = center_at(l, lv.boundary_coords[local]);
      x[side / 2] += (side & 1) ? -0.5 * h : 0.5 * h;
      value = sc.function(x);
    }
    const double inner = v[lv.boundary_source[local]];
    v[g] = sc.kind == BcKind::dirichlet ? 2.0 * value - inner : inner + h * value;
  }
}

template <int D>
void Tree<D>::restrict_and_exchange(std::span<double> v, int coarsest) const {
  restrict_and_exchange(Distribution::Fields{&v, 1}, coarsest);
}

template <int D>
void Tree<D>::restrict_and_exchange(Distribution::Fields fields, int coarsest) const {
  if (!dist_) {
    for (const std::span<double> v : fields)
      for (int l = depth_ - 1; l >= coarsest; --l) restrict_level(l, v);
    return;
  }
  // From the deepest level up: a level's parents are restricted (their children, owned or
  // ghosts, were exchanged one level below), then the level is exchanged once, its leaves
  // (the caller's values) and its parents together, every field in the same message.
  for (int l = global_depth_; l >= coarsest; --l) {
    if (l < depth_)
      for (const std::span<double> v : fields) restrict_level(l, v);
    update_ghosts(l, fields);
  }
}

template <int D>
void Tree<D>::exchange_restricted(std::span<double> v) const {
  if (!dist_) return;
  constexpr int C = kChildren<D>;
  for (int l = global_depth_; l >= 0; --l) {
    if (l < depth_) {
      if (dist_->replicated(l + 1)) {
        restrict_level(l, v);  // every parent: its children came whole by the last exchange
      } else {
        // An owned parent's children are owned, or lie past the end of the range: only the
        // parent of the last group (and, harmlessly, of the first) can have read stale ones.
        const Level<D>& fine = levels_[l + 1];
        const auto [first, last] = owned_groups(l + 1);
        for (Index g = first; g < last; g = (g == first && last - 1 > first) ? last - 1 : last) {
          double sum = 0.0;
          for (int k = 0; k < C; ++k) sum += v[static_cast<std::size_t>(fine.base + g * C + k)];
          v[static_cast<std::size_t>(fine.group_parent[static_cast<std::size_t>(g)])] = sum * (1.0 / C);
        }
      }
    }
    update_ghosts(l, v);
  }
}

template <int D>
void Tree<D>::sync(std::span<double> v, const BoundaryConditions<D>& bc, Prolongation p) const {
  sync(Distribution::Fields{&v, 1}, std::span<const BoundaryConditions<D>>{&bc, 1}, p);
}

template <int D>
void Tree<D>::sync(Distribution::Fields fields, std::span<const BoundaryConditions<D>> bcs, Prolongation p) const {
  CAPSFLOW_ASSERT(fields.size() == bcs.size(), "Tree::sync: one boundary condition per field");
  for (const std::span<double> v : fields)
    CAPSFLOW_ASSERT(v.size() == static_cast<std::size_t>(num_cells_), "Tree::sync: a field does not have num_cells entries");
  restrict_and_exchange(fields, 0);
  for (std::size_t f = 0; f < fields.size(); ++f) fill_outside_leaves(fields[f], bcs[f], p);
}

template <int D>
void Tree<D>::fill_outside_leaves(std::span<double> v, const BoundaryConditions<D>& bc, Prolongation p) const {
  if (p == Prolongation::none) p = Prolongation::linear;
  for (int l = 0; l <= depth_; ++l) {
    fill_halo(l, v, p);
    fill_boundary_cells(l, v, bc);
  }
}

template <int D>
void Tree<D>::sync_leaf_neighbors(std::span<double> v, const BoundaryConditions<D>& bc, Prolongation p,
                                  const InjectedHalos* injected) const {
  CAPSFLOW_ASSERT(v.size() == static_cast<std::size_t>(num_cells_), "Tree::sync_leaf_neighbors: the field does not have num_cells entries");
  // A halo cell of level l is prolonged from level l - 1, whose parents average the
  // levels below: restrict from the deepest level up to the coarsest one a halo reads.
  int coarsest_read = depth_;
  for (int l = 1; l <= depth_; ++l)
    if (levels_[l].n_halo > 0) {
      coarsest_read = l - 1;
      break;
    }
  if (!dist_) {
    restrict_and_exchange(v, coarsest_read);
  } else {
    // Every rank exchanges the same levels: those of any rank's owned leaves and the
    // parents any rank's owned cells read through a halo (set_distribution), restricted.
    for (int l = global_depth_; l >= leaf_sync_exchange_from_; --l) {
      if (l < depth_ && l >= leaf_sync_restrict_from_) restrict_level(l, v);
      update_ghosts(l, v);
    }
  }
  for (int l = 0; l <= depth_; ++l) {
    fill_halo(l, v, p, HaloCells::face_read, injected);
    fill_boundary_cells(l, v, bc);
  }
}

template <int D>
void Tree<D>::sync(FieldId f) {
  sync(std::span<const FieldId>{&f, 1});
}

template <int D>
void Tree<D>::sync(std::span<const FieldId> ids) {
  std::vector<std::span<double>> fields;
  for (const FieldId f : ids) fields.emplace_back(data_.at(f));
  restrict_and_exchange(fields, 0);
  for (std::size_t k = 0; k < ids.size(); ++k)
    fill_outside_leaves(fields[k], fields_.at(ids[k]).bc, fields_.at(ids[k]).prolongation);
}

template <int D>
void Tree<D>::child_values(Index leaf, FieldId f, double* out) const {
  const Prolongation p = fields_[f].prolongation;
  if (p == Prolongation::none) {
    std::fill(out, out + kChildren<D>, 0.0);
    return;
  }
  const auto s = slopes_of<D>(levels_[level_of(leaf)], leaf, data_[f], p);
  for (int k = 0; k < kChildren<D>; ++k) out[k] = s.child(k);
}

template <int D>
void Tree<D>::transfer_fields(const std::vector<Level<D>>& next, int new_depth, Index cells) {
  constexpr int C = kChildren<D>;
  for (std::size_t f = 0; f < fields_.size(); ++f) {
    std::vector<double>& out = data_scratch_[f];
    out.resize(cells);
    const Prolongation p = fields_[f].prolongation;
    if (p == Prolongation::none) {
      std::fill(out.begin(), out.end(), 0.0);
    } else {
      const std::span<const double> in = data_[f];
      for (int l = 0; l <= new_depth; ++l) {
        const Level<D>& nl = next[l];
        const Level<D>* ol = l <= depth_ ? &levels_[l] : nullptr;
#pragma omp parallel for schedule(static) if (nl.n_active > kParallelMin)
        for (Index i = 0; i < nl.n_active; ++i) {
          const Index o = nl.old_index[i];
          if (o == kNone) continue;  // a new child: written by its parent below
          const Index ol_local = o - ol->base;
          const bool was_leaf = ol->leaf[ol_local] != 0;
          const bool is_leaf = nl.leaf[i] != 0;
          if (!was_leaf && is_leaf) {  // coarsened: volume average of the old children
            const Index fc = ol->first_child[ol_local];
            double sum = 0.0;
            for (int k = 0; k < C; ++k) sum += in[fc + k];
            out[nl.base + i] = sum * (1.0 / C);
          } else {
            out[nl.base + i] = in[o];
          }
          if (was_leaf && !is_leaf) {  // refined: prolong from the old leaf and its neighbours
            const auto s = slopes_of<D>(*ol, o, in, p);
            const Index fc = nl.first_child[i];
            for (int k = 0; k < C; ++k) out[fc + k] = s.child(k);
          }
        }
      }
    }
    std::swap(data_[f], out);
  }
}

template FieldId Tree<2>::add_field(FieldSpec<2>);
template void Tree<2>::restrict_level(int, std::span<double>) const;
template void Tree<2>::fill_halo(int, std::span<double>, Prolongation, HaloCells, const InjectedHalos*) const;
template void Tree<2>::fill_halo_groups(int, std::span<double>, Prolongation, HaloCells, const InjectedHalos*, bool) const;
template void Tree<2>::poison_dropped_halos(int, std::span<double>, HaloCells) const;
template void Tree<2>::poison_dropped_boundary_cells(int, std::span<double>) const;
template void Tree<2>::prolong_level(int, std::span<double>, Prolongation) const;
template void Tree<2>::fill_boundary_cells(int, std::span<double>, const BoundaryConditions<2>&) const;
template void Tree<2>::sync(std::span<double>, const BoundaryConditions<2>&, Prolongation) const;
template void Tree<2>::sync(FieldId);
template void Tree<2>::fill_outside_leaves(std::span<double>, const BoundaryConditions<2>&, Prolongation) const;
template void Tree<2>::sync(std::span<const FieldId>);
template void Tree<2>::sync(Distribution::Fields, std::span<const BoundaryConditions<2>>, Prolongation) const;
template void Tree<2>::restrict_and_exchange(Distribution::Fields, int) const;
template void Tree<2>::restrict_and_exchange(std::span<double>, int) const;
template void Tree<2>::exchange_restricted(std::span<double>) const;
template void Tree<2>::sync_leaf_neighbors(std::span<double>, const BoundaryConditions<2>&, Prolongation, const InjectedHalos*) const;
template InjectedHalos Tree<2>::injected_halos(std::span<const std::uint8_t>) const;
template void Tree<2>::refill_injected_halos(std::span<double>, const BoundaryConditions<2>&, Prolongation, const InjectedHalos&) const;
template void Tree<2>::child_values(Index, FieldId, double*) const;
template void Tree<2>::transfer_fields(const std::vector<Level<2>>&, int, Index);
template FieldId Tree<3>::add_field(FieldSpec<3>);
template void Tree<3>::restrict_level(int, std::span<double>) const;
template void Tree<3>::fill_halo(int, std::span<double>, Prolongation, HaloCells, const InjectedHalos*) const;
template void Tree<3>::fill_halo_groups(int, std::span<double>, Prolongation, HaloCells, const InjectedHalos*, bool) const;
template void Tree<3>::poison_dropped_halos(int, std::span<double>, HaloCells) const;
template void Tree<3>::poison_dropped_boundary_cells(int, std::span<double>) const;
template void Tree<3>::prolong_level(int, std::span<double>, Prolongation) const;
template void Tree<3>::fill_boundary_cells(int, std::span<double>, const BoundaryConditions<3>&) const;
template void Tree<3>::sync(std::span<double>, const BoundaryConditions<3>&, Prolongation) const;
template void Tree<3>::sync(FieldId);
template void Tree<3>::fill_outside_leaves(std::span<double>, const BoundaryConditions<3>&, Prolongation) const;
template void Tree<3>::sync(std::span<const FieldId>);
template void Tree<3>::sync(Distribution::Fields, std::span<const BoundaryConditions<3>>, Prolongation) const;
template void Tree<3>::restrict_and_exchange(Distribution::Fields, int) const;
template void Tree<3>::restrict_and_exchange(std::span<double>, int) const;
template void Tree<3>::exchange_restricted(std::span<double>) const;
template void Tree<3>::sync_leaf_neighbors(std::span<double>, const BoundaryConditions<3>&, Prolongation, const InjectedHalos*) const;
template InjectedHalos Tree<3>::injected_halos(std::span<const std::uint8_t>) const;
template void Tree<3>::refill_injected_halos(std::span<double>, const BoundaryConditions<3>&, Prolongation, const InjectedHalos&) const;
template void Tree<3>::child_values(Index, FieldId, double*) const;
template void Tree<3>::transfer_fields(const std::vector<Level<3>>&, int, Index);

}  // namespace capsflow::tree
