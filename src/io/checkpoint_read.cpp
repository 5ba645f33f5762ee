// Checkpoint reader: check the whole file against the run (checksums, shapes, the leaf
// set, finite values, time span, capsules), then rebuild the leaf set by refining from the
// roots and restore the leaf values. The layout is docs/checkpoint-format.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <stdexcept>

#include "io/checkpoint.hpp"
#include "io/checkpoint_values.hpp"
#include "io/checkpoint_header.hpp"
#include "io/h5_file.hpp"

namespace capsflow::io {

namespace {

using detail::Handle;
using detail::H5Io;

template <int D>
tree::Key key_of(const tree::Tree<D>& t, tree::Index c) {
  const tree::Level<D>& lv = t.level(t.level_of(c));
  return lv.keys[static_cast<std::size_t>(c - lv.base)];
}

// Per level, the checkpoint's leaf keys (sorted) with their positions in the file.
struct LeafSet {
  std::vector<std::vector<std::pair<tree::Key, std::size_t>>> levels;
  std::size_t size = 0;
};

template <int D>
LeafSet read_leaf_set(const H5Io& io, hid_t t, const tree::Tree<D>& tree, const std::vector<std::int64_t>& count) {
  const auto keys = io.read<std::uint64_t>(t, "keys", H5T_NATIVE_UINT64, "/tree/keys");
  if (keys.shape.size() != 1) io.fail("/tree/keys must be one-dimensional");
  const int depth = static_cast<int>(count.size()) - 1;
  LeafSet set;
  set.levels.resize(count.size());
  std::size_t at = 0;
  for (int l = 0; l <= depth; ++l) {
    const std::int64_t n = count[static_cast<std::size_t>(l)];
    if (at + static_cast<std::size_t>(n) > keys.values.size())
      io.fail("/tree/leaf_count does not add up to the length of /tree/keys");
    for (std::int64_t i = 0; i < n; ++i, ++at) {
      const tree::Key k = keys.values[at];
      if (!detail::key_in_grid<D>(tree.options(), l, k))
        io.fail(fmt::format("/tree/keys[{}] = {} lies outside the level-{} grid", at, k, l));
      set.levels[static_cast<std::size_t>(l)].emplace_back(k, at);
    }
    std::sort(set.levels[static_cast<std::size_t>(l)].begin(), set.levels[static_cast<std::size_t>(l)].end());
  }
  if (at != keys.values.size()) io.fail("/tree/leaf_count does not add up to the length of /tree/keys");
  set.size = at;
  return set;
}

// Refines the bare roots level by level: a leaf splits when the checkpoint has cells below
// it. The checkpoint's tree was 2:1 balanced, so the balance apply_flags enforces never
// splits a leaf the checkpoint keeps; the final comparison makes sure of it.
template <int D>
void rebuild(const H5Io& io, tree::Tree<D>& tree, const LeafSet& set) {
  const int depth = static_cast<int>(set.levels.size()) - 1;
  std::vector<std::vector<tree::Key>> parents(set.levels.size());
  for (int l = 1; l <= depth; ++l)
    for (const auto& [k, pos] : set.levels[static_cast<std::size_t>(l)])
      for (int m = l - 1; m >= 0; --m) parents[static_cast<std::size_t>(m)].push_back(k >> (D * (l - m)));
  for (auto& p : parents) {
    std::sort(p.begin(), p.end());
    p.erase(std::unique(p.begin(), p.end()), p.end());
  }
  std::vector<std::int8_t> flags;
  for (int pass = 0; pass <= depth; ++pass) {
    flags.assign(static_cast<std::size_t>(tree.num_cells()), 0);
    bool any = false;
    for (const tree::Index c : tree.leaves()) {
      const int l = tree.level_of(c);
      if (l < depth && std::binary_search(parents[static_cast<std::size_t>(l)].begin(),
                                          parents[static_cast<std::size_t>(l)].end(), key_of(tree, c))) {
        flags[static_cast<std::size_t>(c)] = 1;
        any = true;
      }
    }
    if (!any) break;
    (void)tree.apply_flags(flags);
  }
  // Same leaves, level by level?
  std::vector<std::vector<tree::Key>> got(static_cast<std::size_t>(std::max(depth, tree.depth()) + 1));
  for (const tree::Index c : tree.leaves()) got[static_cast<std::size_t>(tree.level_of(c))].push_back(key_of(tree, c));
  for (std::size_t l = 0; l < got.size(); ++l) {
    std::sort(got[l].begin(), got[l].end());
    const std::size_t want = l < set.levels.size() ? set.levels[l].size() : 0;
    bool same = got[l].size() == want;
    for (std::size_t i = 0; same && i < want; ++i) same = got[l][i] == set.levels[l][i].first;
    if (!same)
      io.fail(fmt::format("the leaves of level {} ({} in the file) do not form a balanced tree on these roots "
                          "(rebuilt {}); corrupt /tree/keys?",
                          l, want, got[l].size()));
  }
}

// Each field: one finite value per leaf (read once here, again when restoring, so that
// only one field is in memory at a time).
template <int D>
void check_fields(const H5Io& io, hid_t fields, const tree::Tree<D>& tree, const LeafSet& set) {
  for (tree::FieldId f = 0; f < tree.num_fields(); ++f) {
    if (!tree.field_spec(f).saved) continue;
    const std::string path = "/fields/" + tree.field_spec(f).name;
    const auto a = io.read<double>(fields, tree.field_spec(f).name, H5T_NATIVE_DOUBLE, path);
    if (a.values.size() != set.size)
      io.fail(fmt::format("{} holds {} values for {} leaves", path, a.values.size(), set.size));
    detail::check_finite(io, path, a.values);
  }
}

template <int D>
void restore_fields(const H5Io& io, hid_t fields, tree::Tree<D>& tree, const LeafSet& set) {
  // File position of each leaf of the rebuilt tree: match keys level by level.
  std::vector<std::pair<tree::Index, std::size_t>> where;
  where.reserve(set.size);
  std::vector<std::vector<std::pair<tree::Key, tree::Index>>> cells(set.levels.size());
  for (const tree::Index c : tree.leaves())
    cells[static_cast<std::size_t>(tree.level_of(c))].emplace_back(key_of(tree, c), c);
  for (std::size_t l = 0; l < cells.size(); ++l) {
    std::sort(cells[l].begin(), cells[l].end());
    for (std::size_t i = 0; i < cells[l].size(); ++i) where.emplace_back(cells[l][i].second, set.levels[l][i].second);
  }
  for (tree::FieldId f = 0; f < tree.num_fields(); ++f) {
    if (!tree.field_spec(f).saved) continue;
    const std::string& name = tree.field_spec(f).name;
    const auto a = io.read<double>(fields, name, H5T_NATIVE_DOUBLE, "/fields/" + name);
    if (a.values.size() != set.size)
      io.fail(fmt::format("/fields/{} holds {} values for {} leaves", name, a.values.size(), set.size));
    const std::span<double> v = tree.values(f);
    for (const auto& [cell, pos] : where) v[static_cast<std::size_t>(cell)] = a.values[pos];
    if (tree.field_spec(f).prolongation != tree::Prolongation::none) tree.sync(f);
  }
}

}  // namespace

template <int D>
RestoredState read_checkpoint(const std::filesystem::path& path, tree::Tree<D>& tree,
                              const CheckpointExpectations& expect) {
  if (tree.depth() != 0)
    throw std::invalid_argument("read_checkpoint: the tree must be its bare roots (build it from the case)");
  const detail::QuietErrors quiet;
  H5Io io(path.string(), H5Io::Mode::read);
  const detail::CheckpointHeader header = detail::read_header(io, path, tree);
  const hid_t root = header.file.get();
  const Handle t = io.group(root, "tree", false);
  const LeafSet set = read_leaf_set(io, t.get(), tree, header.leaf_count);
  RestoredState state = detail::read_scalars_and_extras(io, root, expect, {});

  const Handle f = io.group(root, "fields", false);
  detail::check_field_names(io, f.get(), tree);
  check_fields(io, f.get(), tree, set);

  // The whole file is checked before the tree changes: rebuild the leaf set on a scratch
  // forest first (a corrupt set fails there), then on the run's tree.
  tree::Tree<D> scratch(tree.options());
  rebuild(io, scratch, set);
  rebuild(io, tree, set);
  restore_fields(io, f.get(), tree, set);
  return state;
}

template RestoredState read_checkpoint<2>(const std::filesystem::path&, tree::Tree<2>&,
                                          const CheckpointExpectations&);
template RestoredState read_checkpoint<3>(const std::filesystem::path&, tree::Tree<3>&,
                                          const CheckpointExpectations&);

}  // namespace capsflow::io
