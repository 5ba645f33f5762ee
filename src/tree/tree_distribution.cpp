// The local tree's view of its distribution (docs/parallel.md): each cell's role (owned,
// ghost, placeholder), the owned sibling groups of every level, and the cells outside them
// that the loops which skip the rest must still visit: the ghosts whose faces owned cells
// read (face_ghosts_), the halo groups whose values reach owned cells (held_halo_) and the
// boundary cells filled from held values (held_boundary_fill_).
#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "tree/tree.hpp"

namespace capsflow::tree {

template <int D>
void Tree<D>::set_distribution(const Distribution* d, std::vector<std::uint8_t> roles,
                               DistributedAdaptation<D>* adaptation) {
  dist_adapt_ = adaptation;
  if (d == nullptr) {
    dist_ = nullptr;
    roles_.clear();
    owned_leaves_.clear();
    owned_groups_.clear();
    face_ghosts_.clear();
    held_boundary_fill_.clear();
    held_boundary_fill_faces_.clear();
    global_depth_ = depth_;
    return;
  }
  if (roles.size() != static_cast<std::size_t>(num_cells_))
    throw std::invalid_argument("Tree::set_distribution: the roles need one entry per cell");
  dist_ = d;
  roles_ = std::move(roles);
  owned_leaves_.clear();
  for (const Index c : leaves_)
    if (owns(c)) owned_leaves_.push_back(c);
  owned_groups_.assign(static_cast<std::size_t>(depth_) + 1, {0, 0});
  for (int l = 1; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    Index first = lv.n_active, last = -1;
    for (Index i = 0; i < lv.n_active; ++i)
      if (owns(lv.base + i)) {
        first = std::min(first, i);
        last = i;
      }
    if (last >= 0) owned_groups_[static_cast<std::size_t>(l)] = {first / kChildren<D>, last / kChildren<D> + 1};
  }
  collect_face_ghosts();
  collect_held_halos();  // after face_ghosts_: the face loops read their halos too
  collect_held_boundary_fill();
  global_depth_ = static_cast<int>(d->max(static_cast<std::int64_t>(depth_)));
  // The halos owned cells read, and the owned leaves' levels (sync_leaf_neighbors): the
  // local tree's own halos next to its placeholders would otherwise make every rank restrict
  // and exchange every level, though no owned stencil reads them.
  std::int64_t reads = depth_, leaf_level = depth_;
  for (int l = 1; l <= depth_ && reads == depth_; ++l) {
    const Level<D>& lv = levels_[l];
    for (Index i = 0; i < lv.n_active && reads == depth_; ++i) {
      if (!owns(lv.base + i)) continue;
      const Index* row = lv.face_row(lv.base + i);
      for (int k = 0; k < kFaces<D>; ++k)
        if (row[k] >= lv.halo_begin() && row[k] < lv.halo_end()) reads = l - 1;
    }
  }
  for (const Index c : owned_leaves_) leaf_level = std::min<std::int64_t>(leaf_level, level_of(c));
  leaf_sync_restrict_from_ = static_cast<int>(-d->max(-reads));
  leaf_sync_exchange_from_ = std::min(leaf_sync_restrict_from_, static_cast<int>(-d->max(-leaf_level)));
}

template <int D>
void Tree<D>::collect_held_halos() {
  constexpr int C = kChildren<D>;
  // The halo groups a stencil reaching an owned cell reads: those in the 3^D block of an
  // owned active cell (every cell of a replicated level, of the owned groups and of
  // face_ghosts_, whose faces the face loops compute) or of its face neighbours (face
  // stencils, BCG's transverse terms), their own halo children (a flux against a finer
  // neighbour), and in the block of their parents (the multigrid's first half-sweep reads
  // the face neighbours' prolonged corrections before any exchange); then upward, the block
  // of the coarse leaf of every such group (its prolongation reads it). The others, next to
  // ghosts only, are never read by a value that reaches an owned cell (docs/parallel.md
  // gives the versions of this rule that the tests rejected).
  std::vector<std::vector<std::uint8_t>> read(static_cast<std::size_t>(depth_) + 1);
  for (int l = 0; l <= depth_; ++l) read[static_cast<std::size_t>(l)].assign(static_cast<std::size_t>(levels_[l].n_halo / C), 0);
  auto mark_block = [&](int l, Index cell) {
    const Level<D>& lv = levels_[l];
    // The rows as arrays, and one test of the whole block first: most blocks hold no halo
    // cell (this was the most of the attach after an adaptation).
    const std::size_t r = Level<D>::row_of(cell - lv.base);
    const Index* face = lv.face.data() + r * kFaces<D>;
    const Index* diag = lv.diag.data() + r * kDiagonals<D>;
    const auto halo_begin = static_cast<std::uint32_t>(lv.halo_begin()), n_halo = static_cast<std::uint32_t>(lv.n_halo);
    bool any = false;
    for (int s = 0; s < kFaces<D>; ++s) any |= static_cast<std::uint32_t>(face[s]) - halo_begin < n_halo;
    for (int s = 0; s < kDiagonals<D>; ++s) any |= static_cast<std::uint32_t>(diag[s]) - halo_begin < n_halo;
    if (!any) return;
    auto& marks = read[static_cast<std::size_t>(l)];
    auto mark = [&](Index n) {
      if (static_cast<std::uint32_t>(n) - halo_begin < n_halo) marks[static_cast<std::size_t>((n - lv.halo_begin()) / C)] = 1;
    };
    for (int s = 0; s < kFaces<D>; ++s) mark(face[s]);
    for (int s = 0; s < kDiagonals<D>; ++s) mark(diag[s]);
  };
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(num_cells_), 0);
  auto reach = [&](int l, Index cell) {  // a cell whose stencils reach an owned value
    if (seen[static_cast<std::size_t>(cell)] & 1) return;
    seen[static_cast<std::size_t>(cell)] |= 1;
    mark_block(l, cell);
    const Level<D>& lv = levels_[l];
    if (l < depth_) {
      const Level<D>& fine = levels_[l + 1];
      const Index first = lv.first_child[static_cast<std::size_t>(cell - lv.base)];
      if (first != kNone && first >= fine.halo_begin() && first < fine.halo_end())
        read[static_cast<std::size_t>(l + 1)][static_cast<std::size_t>((first - fine.halo_begin()) / C)] = 1;
    }
    if (l == 0) return;
    const Index parent = lv.group_parent[static_cast<std::size_t>((cell - lv.base) / C)];
    if (seen[static_cast<std::size_t>(parent)] & 2) return;
    seen[static_cast<std::size_t>(parent)] |= 2;
    mark_block(l - 1, parent);
  };
  for (int l = 0; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    // The face loops compute the faces of the ghosts in face_ghosts_ and of every cell of
    // the owned groups from their neighbours (restricted into owned coarse faces).
    for (const Index g : face_ghosts_[static_cast<std::size_t>(l)]) reach(l, g);
    const auto [begin, end] = owned_range(l);
    for (Index i = begin; i < end; ++i)
      if (holds(lv.base + i)) reach(l, lv.base + i);
    const bool replicated = dist_->replicated(l);  // every rank relaxes every cell there
    for (Index i = 0; i < lv.n_active; ++i) {
      const Index c = lv.base + i;
      if (!owns(c) && !replicated) continue;
      reach(l, c);
      const Index* row = lv.face_row(c);
      for (int k = 0; k < kFaces<D>; ++k)
        if (row[k] >= lv.base && row[k] < lv.active_end()) reach(l, row[k]);
    }
  }
  for (int l = depth_; l >= 2; --l) {
    const Level<D>& lv = levels_[l];
    for (std::size_t g = 0; g < read[static_cast<std::size_t>(l)].size(); ++g)
      if (read[static_cast<std::size_t>(l)][g]) mark_block(l - 1, lv.halo_parent[g]);
  }
  for (auto& lists : held_halo_) lists.assign(static_cast<std::size_t>(depth_) + 1, {});
  for (int l = 1; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    const auto& needed = read[static_cast<std::size_t>(l)];
    auto& all = held_halo_[static_cast<std::size_t>(HaloCells::all)][static_cast<std::size_t>(l)];
    auto& face_read = held_halo_[static_cast<std::size_t>(HaloCells::face_read)][static_cast<std::size_t>(l)];
    for (Index g = 0; g < lv.n_halo / C; ++g)
      if (needed[static_cast<std::size_t>(g)] && holds(lv.halo_parent[static_cast<std::size_t>(g)])) all.push_back(g);
    for (const Index g : lv.halo_read)
      if (needed[static_cast<std::size_t>(g)] && holds(lv.halo_parent[static_cast<std::size_t>(g)])) face_read.push_back(g);
  }
}

template <int D>
void Tree<D>::collect_held_boundary_fill() {
  constexpr int C = kChildren<D>;
  held_boundary_fill_.assign(static_cast<std::size_t>(depth_) + 1, {});
  held_boundary_fill_faces_.assign(static_cast<std::size_t>(depth_) + 1, 0);
  for (int l = 0; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    std::vector<std::uint8_t> held_halo(static_cast<std::size_t>(lv.n_halo / C), 0), kept(static_cast<std::size_t>(lv.n_boundary), 0);
    if (l > 0)
      for (const Index g : held_halo_[static_cast<std::size_t>(HaloCells::all)][static_cast<std::size_t>(l)])
        held_halo[static_cast<std::size_t>(g)] = 1;
    auto& list = held_boundary_fill_[static_cast<std::size_t>(l)];
    for (std::size_t i = 0; i < lv.boundary_fill.size(); ++i) {
      if (i == static_cast<std::size_t>(lv.boundary_fill_faces))
        held_boundary_fill_faces_[static_cast<std::size_t>(l)] = static_cast<Index>(list.size());
      const Index g = lv.boundary_fill[i];
      const Index source = lv.boundary_source[static_cast<std::size_t>(g - lv.boundary_begin())];
      bool held = false;
      if (source < lv.halo_begin()) held = holds(source);  // an active cell
      else if (source < lv.halo_end()) held = held_halo[static_cast<std::size_t>((source - lv.halo_begin()) / C)] != 0;
      else held = kept[static_cast<std::size_t>(source - lv.boundary_begin())] != 0;  // edges, corners: after their source
      if (!held) continue;
      kept[static_cast<std::size_t>(g - lv.boundary_begin())] = 1;
      list.push_back(g);
    }
    if (lv.boundary_fill_faces == static_cast<Index>(lv.boundary_fill.size()))
      held_boundary_fill_faces_[static_cast<std::size_t>(l)] = static_cast<Index>(list.size());
  }
}

template <int D>
void Tree<D>::collect_face_ghosts() {
  face_ghosts_.assign(static_cast<std::size_t>(depth_) + 1, {});
  std::vector<std::uint8_t> marked(static_cast<std::size_t>(num_cells_), 0);
  std::vector<std::pair<Index, Index>> ranges;  // owned_range per level, asked once
  for (int l = 0; l <= depth_; ++l) ranges.push_back(owned_range(l));
  auto mark = [&](int l, Index c) {
    const Level<D>& lv = levels_[l];
    const auto [begin, end] = ranges[static_cast<std::size_t>(l)];
    const Index i = c - lv.base;
    if (c < lv.base || c >= lv.active_end() || (i >= begin && i < end) || !lv.is_leaf(c) || !holds(c) ||
        marked[static_cast<std::size_t>(c)])
      return;
    marked[static_cast<std::size_t>(c)] = 1;
    face_ghosts_[static_cast<std::size_t>(l)].push_back(c);
  };
  auto mark_children = [&](int l, Index parent) {
    const Level<D>& lv = levels_[l];
    for (int b = 0; b < kChildren<D>; ++b) mark(l + 1, lv.first_child[static_cast<std::size_t>(parent - lv.base)] + b);
  };
  for (int l = 0; l <= depth_; ++l) {
    const Level<D>& lv = levels_[l];
    for (Index i = 0; i < lv.n_active; ++i) {
      const Index c = lv.base + i;
      if (!owns(c)) continue;
      if (!lv.leaf[i]) mark_children(l, c);  // an owned parent's slots are restricted from them
      const Index* row = lv.face_row(c);
      for (int k = 0; k < kFaces<D>; ++k) {
        const Index n = row[k];
        if (n < lv.base || n >= lv.active_end()) continue;
        if (lv.is_leaf(n)) mark(l, n);
        else if (lv.leaf[i]) mark_children(l, n);  // the fine faces of an owned leaf's coarse ones
      }
    }
  }
  for (auto& list : face_ghosts_) std::ranges::sort(list);
}

template void Tree<2>::set_distribution(const Distribution*, std::vector<std::uint8_t>, DistributedAdaptation<2>*);
template void Tree<2>::collect_held_halos();
template void Tree<2>::collect_held_boundary_fill();
template void Tree<2>::collect_face_ghosts();
template void Tree<3>::set_distribution(const Distribution*, std::vector<std::uint8_t>, DistributedAdaptation<3>*);
template void Tree<3>::collect_held_halos();
template void Tree<3>::collect_held_boundary_fill();
template void Tree<3>::collect_face_ghosts();

}  // namespace capsflow::tree
