// Deciding where the forest changes: the wavelet error estimate, forced refinement, the
// 2:1 balance of refinement and of coarsening. The topology is then rebuilt (tree_build.cpp).
//
// Wavelet (Basilisk's adapt_wavelet): with every field restricted to the parents, the error
// of a cell is |u_c - (prolongation of its parent)(x_c)|, the detail the parent's linear
// reconstruction misses. A leaf above tolerance is split; a parent whose children are all
// leaves below tolerance/1.5 (hysteresis) is merged, one level per call.
//
// Balance. Splitting leaf c of level l needs all 3^D - 1 neighbours of c at level l to be
// cells: a halo neighbour means a coarse leaf of level l-1 there, which must split too
// (and so on, coarser). Merging parent P of level l into a leaf is refused when a
// neighbour of P has a child that is a parent or is being split (a leaf of level l+2 would
// touch the new leaf of level l).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "tree/prolongation.hpp"
#include "tree/tree.hpp"

namespace capsflow::tree {

template <int D>
void Tree<D>::wavelet_error(std::span<const WaveletTolerance> criteria,
                            std::vector<float>& error) const {
  constexpr int C = kChildren<D>;
  error.assign(num_cells_, 0.0f);
  for (const WaveletTolerance& crit : criteria) {
    if (!(crit.tolerance > 0.0))
      throw std::invalid_argument(fmt::format("tree: wavelet tolerance of field '{}' must be > 0, got {}",
                                              field_spec(crit.field).name, crit.tolerance));
    const std::span<const double> v = data_.at(crit.field);
    const Prolongation p = fields_[crit.field].prolongation == Prolongation::limited
                               ? Prolongation::limited
                               : Prolongation::linear;
    const double inv = 1.0 / crit.tolerance;
    for (int l = 0; l < depth_; ++l) {
      const Level<D>& lv = levels_[l];
#pragma omp parallel for schedule(static) if (lv.n_active > kParallelMin / kChildren<D>)
      for (Index i = 0; i < lv.n_active; ++i) {
        if (lv.leaf[i]) continue;
        const Index parent = lv.base + i;
        const Index* row = lv.face_row(parent);
        double lo[D], hi[D];
        for (int d = 0; d < D; ++d) {
          lo[d] = v[row[2 * d]];
          hi[d] = v[row[2 * d + 1]];
        }
        const auto s = p == Prolongation::limited ? ParentSlopes<D>::limited(v[parent], lo, hi)
                                                  : ParentSlopes<D>::linear(v[parent], lo, hi);
        const Index fc = lv.first_child[i];
        for (int k = 0; k < C; ++k) {
          const auto e = static_cast<float>(std::abs(v[fc + k] - s.child(k)) * inv);
          error[fc + k] = std::max(error[fc + k], e);
        }
      }
    }
  }
}

template <int D>
AdaptCounts Tree<D>::adapt(const AdaptOptions<D>& opt) {
  const int max_l = opt.max_level < 0 ? options_.max_level : opt.max_level;
  if (max_l > options_.max_level)
    throw std::invalid_argument(fmt::format("tree: adapt max_level {} exceeds the tree's max_level {}",
                                            max_l, options_.max_level));
  if (opt.min_level < 0 || opt.min_level > max_l)
    throw std::invalid_argument(fmt::format("tree: adapt min_level {} is outside [0, max_level {}]",
                                            opt.min_level, max_l));
  for (const WaveletTolerance& c : opt.criteria)
    if (c.field < 0 || c.field >= num_fields())
      throw std::invalid_argument(fmt::format("tree: adapt criterion names field {}, which does not exist", c.field));
  if (!opt.criteria_mask.empty() && static_cast<Index>(opt.criteria_mask.size()) != num_cells_)
    throw std::invalid_argument(fmt::format("tree: adapt criteria mask of {} entries for {} cells", opt.criteria_mask.size(), num_cells_));
  for (FieldId f = 0; f < num_fields(); ++f)
    if (fields_[f].prolongation != Prolongation::none) sync(f);
  wavelet_error(opt.criteria, error_);
  if (!opt.criteria_mask.empty())
    for (Index c = 0; c < num_cells_; ++c)
      if (!opt.criteria_mask[static_cast<std::size_t>(c)]) error_[static_cast<std::size_t>(c)] = 0.0f;

  flags_.assign(num_cells_, 0);
  const float coarse_below = static_cast<float>(1.0 / 1.5);
  for (int l = 0; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
#pragma omp parallel for schedule(dynamic, 1024) if (lv.n_active > kParallelMin)
    for (Index i = 0; i < lv.n_active; ++i) {
      if (!lv.leaf[i]) continue;
      const Index c = lv.base + i;
      int required = opt.min_level;
      if (opt.required_level) required = std::max(required, std::min(opt.required_level(box(c)), max_l));
      std::int8_t flag = 0;
      if (l > max_l) flag = -1;
      else if (l < max_l && (error_[c] > 1.0f || required > l)) flag = 1;
      else if (opt.allow_coarsening && l > opt.min_level && error_[c] <= coarse_below && required < l)
        flag = -1;
      flags_[c] = flag;
    }
  }
  return decide_and_rebuild(opt.min_level);
}

template <int D>
AdaptCounts Tree<D>::apply_flags(std::span<const std::int8_t> flags, int min_level) {
  if (static_cast<Index>(flags.size()) != num_cells_)
    throw std::invalid_argument(fmt::format("tree: {} refinement flags for {} cells", flags.size(), num_cells_));
  flags_.assign(flags.begin(), flags.end());
  for (FieldId f = 0; f < num_fields(); ++f)
    if (fields_[f].prolongation != Prolongation::none) sync(f);
  return decide_and_rebuild(min_level);
}

template <int D>
AdaptCounts Tree<D>::decide_and_rebuild(int min_level) {
  if (dist_adapt_) return dist_adapt_->adapt(*this, min_level);  // replaces this tree
  AdaptCounts counts = decide(min_level);
  if (counts.refined > 0 || counts.coarsened > 0) rebuild(refined_next_);
  counts.leaves = num_leaves();
  counts.cells = num_cells_;
  return counts;
}

template <int D>
AdaptCounts Tree<D>::decide(int min_level) {
  constexpr int C = kChildren<D>;
  AdaptCounts counts;
  // 1. Split flagged leaves; a split leaf drags its coarser neighbours along (balance).
  std::vector<std::pair<Index, int>>& stack = balance_stack_;
  stack.clear();
  for (int l = 0; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    for (Index i = 0; i < lv.n_active; ++i) {
      const Index c = lv.base + i;
      if (!lv.leaf[i] || flags_[c] != 1) continue;
      if (l == options_.max_level) flags_[c] = 0;
      else stack.emplace_back(c, l);
    }
  }
  while (!stack.empty()) {
    const auto [c, l] = stack.back();
    stack.pop_back();
    const Level<D>& lv = levels_[l];
    for (int s = 0; s < kStencil<D>; ++s) {
      const Index n = lv.neighbor(c, s);
      if (n < lv.halo_begin() || n >= lv.halo_end()) continue;
      const Index coarse = lv.halo_parent[(n - lv.halo_begin()) / C];
      if (flags_[coarse] == 1) continue;
      flags_[coarse] = 1;
      stack.emplace_back(coarse, l - 1);
    }
  }
  // 2. Which cells have children in the next tree.
  refined_next_.assign(num_cells_, 0);
  for (int l = 0; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    Index refined = 0, coarsened = 0;
#pragma omp parallel for schedule(static) reduction(+ : refined, coarsened) if (lv.n_active > kParallelMin)
    for (Index i = 0; i < lv.n_active; ++i) {
      const Index c = lv.base + i;
      if (lv.leaf[i]) {
        refined_next_[c] = flags_[c] == 1;
        refined += flags_[c] == 1;
        continue;
      }
      refined_next_[c] = 1;
      if (l < min_level) continue;
      const Index fc = lv.first_child[i];
      const Level<D>& fine = levels_[l + 1];
      bool merge = true;
      for (int k = 0; k < C && merge; ++k)
        merge = fine.leaf[fc + k - fine.base] && flags_[fc + k] == -1;
      // No neighbour may keep (or get) cells two levels finer than the merged leaf.
      for (int s = 0; s < kStencil<D> && merge; ++s) {
        const Index n = lv.neighbor(c, s);
        if (n >= lv.active_end() || lv.leaf[n - lv.base]) continue;
        const Index nfc = lv.first_child[n - lv.base];
        for (int k = 0; k < C && merge; ++k)
          merge = fine.leaf[nfc + k - fine.base] && flags_[nfc + k] != 1;
      }
      if (merge) {
        refined_next_[c] = 0;
        ++coarsened;
      }
    }
    counts.refined += refined;
    counts.coarsened += coarsened;
  }
  return counts;
}

template <int D>
AdaptCounts Tree<D>::refine_to(const std::function<int(const Box<D>&)>& required_level,
                               int max_passes) {
  AdaptOptions<D> opt;
  opt.required_level = required_level;
  opt.allow_coarsening = false;
  AdaptCounts total;
  for (int pass = 0; pass < max_passes; ++pass) {
    const AdaptCounts c = adapt(opt);
    total.refined += c.refined;
    total.leaves = c.leaves;
    total.cells = c.cells;
    if (global_sum(std::int64_t{c.refined}) == 0) return total;  // every rank agrees (counts are each rank's)
  }
  throw std::runtime_error(fmt::format("tree: refine_to did not settle in {} passes", max_passes));
}

template void Tree<2>::wavelet_error(std::span<const WaveletTolerance>, std::vector<float>&) const;
template AdaptCounts Tree<2>::adapt(const AdaptOptions<2>&);
template AdaptCounts Tree<2>::apply_flags(std::span<const std::int8_t>, int);
template AdaptCounts Tree<2>::decide_and_rebuild(int);
template AdaptCounts Tree<2>::decide(int);
template AdaptCounts Tree<2>::refine_to(const std::function<int(const Box<2>&)>&, int);
template void Tree<3>::wavelet_error(std::span<const WaveletTolerance>, std::vector<float>&) const;
template AdaptCounts Tree<3>::adapt(const AdaptOptions<3>&);
template AdaptCounts Tree<3>::apply_flags(std::span<const std::int8_t>, int);
template AdaptCounts Tree<3>::decide_and_rebuild(int);
template AdaptCounts Tree<3>::decide(int);
template AdaptCounts Tree<3>::refine_to(const std::function<int(const Box<3>&)>&, int);

}  // namespace capsflow::tree
