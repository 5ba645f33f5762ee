// Checkpoint reader: check the whole file against the run (checksums, shapes, the leaf
// set, finite values, time span, capsules), then rebuild the leaf set by refining from the
// roots and restore the leaf values. The layout is docs/checkpoint-format.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <stdexcept>

#include "io/checkpoint.hpp"
#include "io/checkpoint_values.hpp"
#include "io/h5_file.hpp"

namespace capsflow::io {

namespace {

using detail::Handle;
using detail::H5Io;

template <class T>
T scalar(const detail::Array<T>& a, const H5Io& io, const std::string& path) {
  if (a.values.size() != 1) io.fail(fmt::format("{} holds {} values, expected one", path, a.values.size()));
  return a.values[0];
}

template <int D>
void check_options(const H5Io& io, hid_t t, const tree::TreeOptions<D>& o) {
  const auto roots = io.read_attribute<std::int32_t>(t, "roots", H5T_NATIVE_INT32, "/tree@roots").values;
  const auto periodic = io.read_attribute<std::int32_t>(t, "periodic", H5T_NATIVE_INT32, "/tree@periodic").values;
  const auto origin = io.read_attribute<double>(t, "origin", H5T_NATIVE_DOUBLE, "/tree@origin").values;
  const double size = scalar(io.read_attribute<double>(t, "root_size", H5T_NATIVE_DOUBLE, "/tree@root_size"),
                             io, "/tree@root_size");
  std::vector<std::int32_t> run_roots(o.roots.begin(), o.roots.end()), run_periodic;
  for (const bool p : o.periodic) run_periodic.push_back(p ? 1 : 0);
  const std::vector<double> run_origin(o.origin.begin(), o.origin.end());
  if (roots != run_roots)
    io.fail(fmt::format("domain.roots is [{}] in the checkpoint but [{}] in this run", fmt::join(roots, ", "),
                        fmt::join(run_roots, ", ")));
  if (periodic != run_periodic)
    io.fail(fmt::format("domain.periodic is [{}] in the checkpoint but [{}] in this run (1 = periodic)",
                        fmt::join(periodic, ", "), fmt::join(run_periodic, ", ")));
  if (size != o.root_size)
    io.fail(fmt::format("domain.root_size is {} in the checkpoint but {} in this run", size, o.root_size));
  if (origin != run_origin)
    io.fail(fmt::format("domain.origin is [{}] in the checkpoint but [{}] in this run", fmt::join(origin, ", "),
                        fmt::join(run_origin, ", ")));
}

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
LeafSet read_leaf_set(const H5Io& io, hid_t t, const tree::Tree<D>& tree) {
  const auto count = io.read<std::int64_t>(t, "leaf_count", H5T_NATIVE_INT64, "/tree/leaf_count");
  const auto keys = io.read<std::uint64_t>(t, "keys", H5T_NATIVE_UINT64, "/tree/keys");
  if (count.shape.size() != 1 || count.values.empty() || keys.shape.size() != 1)
    io.fail("/tree/leaf_count and /tree/keys must be one-dimensional and non-empty");
  const int depth = static_cast<int>(count.values.size()) - 1;
  if (depth > tree.max_level())
    io.fail(fmt::format("leaves at level {}, deeper than adapt.max_level = {} of this run", depth,
                        tree.max_level()));
  LeafSet set;
  set.levels.resize(count.values.size());
  std::size_t at = 0;
  for (int l = 0; l <= depth; ++l) {
    const std::int64_t n = count.values[static_cast<std::size_t>(l)];
    if (n < 0 || at + static_cast<std::size_t>(n) > keys.values.size())
      io.fail("/tree/leaf_count does not add up to the length of /tree/keys");
    for (std::int64_t i = 0; i < n; ++i, ++at) {
      const tree::Key k = keys.values[at];
      const tree::Coords<D> ijk = tree::morton_decode<D>(k);
      for (int d = 0; d < D; ++d)
        if (ijk[d] >= (tree.options().roots[d] << l))
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

template <int D>
void check_field_names(const H5Io& io, hid_t fields, const tree::Tree<D>& tree) {
  const std::vector<std::string> in_file = io.members(fields, "/fields");
  std::vector<std::string> in_run;
  for (tree::FieldId f = 0; f < tree.num_fields(); ++f)
    if (tree.field_spec(f).saved) in_run.push_back(tree.field_spec(f).name);
  std::sort(in_run.begin(), in_run.end());
  if (in_file != in_run)
    io.fail(fmt::format("the fields differ: the checkpoint has [{}], this run registers [{}]",
                        fmt::join(in_file, ", "), fmt::join(in_run, ", ")));
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
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) io.fail("no such checkpoint file");
  const Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid())
    io.fail(detail::error_stack_mentions_checksum() ? "not a readable HDF5 file (checksum mismatch: corrupt)"
                                                    : "not a readable HDF5 file (truncated or corrupt?)");
  const hid_t root = file.get();

  if (H5Aexists(root, "format") <= 0 || io.read_string_attribute(root, "format", "/@format") != detail::kCheckpointFormat)
    io.fail("not a capsflow checkpoint (no /@format = \"capsflow checkpoint\")");
  const auto version = scalar(io.read_attribute<std::int32_t>(root, "format_version", H5T_NATIVE_INT32, "/@format_version"),
                              io, "/@format_version");
  if (version < detail::kOldestCheckpointVersion || version > detail::kCheckpointVersion)
    io.fail(fmt::format("checkpoint format version {}, this capsflow reads versions {} to {}", version,
                        detail::kOldestCheckpointVersion, detail::kCheckpointVersion));
  io.expect_format_version(version);
  const auto dim = scalar(io.read_attribute<std::int32_t>(root, "dimension", H5T_NATIVE_INT32, "/@dimension"),
                          io, "/@dimension");
  if (dim != D) io.fail(fmt::format("written by a {}D run, this run is {}D", dim, D));

  const Handle t = io.group(root, "tree", false);
  check_options<D>(io, t.get(), tree.options());
  const LeafSet set = read_leaf_set(io, t.get(), tree);

  RestoredState state;
  const Handle s = io.group(root, "scalars", false);
  state.scalars.time = scalar(io.read<double>(s.get(), "time", H5T_NATIVE_DOUBLE, "/scalars/time"), io, "/scalars/time");
  state.scalars.step = scalar(io.read<std::int64_t>(s.get(), "step", H5T_NATIVE_INT64, "/scalars/step"), io, "/scalars/step");
  state.scalars.dt = scalar(io.read<double>(s.get(), "dt", H5T_NATIVE_DOUBLE, "/scalars/dt"), io, "/scalars/dt");
  detail::check_scalars(io, state.scalars, expect);
  const Handle e = io.group(root, "extras", false);
  for (const std::string& name : io.members(e.get(), "/extras")) {
    auto a = io.read<double>(e.get(), name, H5T_NATIVE_DOUBLE, "/extras/" + name);
    detail::check_finite(io, "/extras/" + name, a.values);
    state.extras.push_back({.name = name,
                            .shape = std::vector<std::size_t>(a.shape.begin(), a.shape.end()),
                            .values = std::move(a.values)});
  }
  detail::check_capsules(io, state.extras, expect);

  const Handle f = io.group(root, "fields", false);
  check_field_names(io, f.get(), tree);
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
