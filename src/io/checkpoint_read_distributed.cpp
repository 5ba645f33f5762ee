// The checkpoint reader of N ranks: each rank reads one share of the rows, the leaves travel
// to the ranks that own them along the curve, and the checks of the one-rank reader are made
// on the distributed leaves (docs/checkpoint-format.md, "Reading on N ranks").
//
// 1. Rank r reads rows [r L / P, (r + 1) L / P) of /tree/keys, of every field and of every
//    per-leaf extra (L leaves), and adds its terms of their checksums; one reduction compares
//    the sums with the stored ones.
// 2. The rows are level by level in the file, so a rank's share spans the whole curve: the
//    ranks agree on P - 1 curve positions that split the leaves into equal counts (a
//    bisection, every rank counting its own leaves below each candidate: one reduction of
//    P - 1 counts a round), send each leaf there with its values, and sort what they get.
// 3. In curve order the leaves must tile every root: each leaf starts where the one before it
//    ends, or at the next root's start when that one ends its root (the ranks' first and last
//    leaves are compared across ranks); and they must be 2:1 balanced as Tree::adapt keeps
//    them (the 3^D neighbours of a level-l leaf's parent exist), which a rank checks with its
//    own leaves and by asking the owners of the others.
// 4. The partition by leaf count (Partition::by_weight, as tree::distribute makes it), the
//    plan and the local tree; leaf values restored, every field synced.
// No rank holds more than its share of the file; failures are agreed on (every rank throws
// the same CheckpointError) before the next collective step.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <bit>
#include <functional>
#include <numeric>
#include <optional>
#include <stdexcept>

#include "io/checkpoint.hpp"
#include "io/checkpoint_header.hpp"
#include "io/checkpoint_values.hpp"
#include "io/h5_file.hpp"
#include "parallel/all_or_none.hpp"
#include "parallel/sparse_exchange.hpp"
#include "tree/curve_stencil.hpp"
#include "tree/leaf_migration.hpp"
#include "tree/leaf_order.hpp"

namespace capsflow::io {

namespace {

using detail::H5Io;
using detail::Handle;
using tree::CurveCell;
using tree::Key;
__extension__ typedef __int128 I128;  // row and leaf counts times the rank count

// `local` on every rank; if it threw on any, every rank throws that of the lowest one as a
// CheckpointError (a checkpoint that cannot restart the run).
void agree(const parallel::Comm& comm, const std::function<void()>& local) {
  try {
    parallel::all_or_none(comm, local);
  } catch (const CheckpointError&) {
    throw;
  } catch (const std::runtime_error& e) {
    throw CheckpointError(e.what());
  }
}

// This rank's leaves with their values (components per leaf: the saved fields in name
// order, then the per-leaf extras' values).
struct Share {
  std::vector<CurveCell> leaves;
  std::vector<double> values;
  int components = 1;
};

// Sorts a share in curve order (the values move with their leaves).
void sort_share(Share& s) {
  std::vector<std::size_t> order(s.leaves.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return tree::curve_less(s.leaves[a], s.leaves[b]); });
  const auto per = static_cast<std::size_t>(s.components);
  Share sorted{.leaves = {}, .values = {}, .components = s.components};
  sorted.leaves.reserve(s.leaves.size());
  sorted.values.reserve(s.values.size());
  for (const std::size_t i : order) {
    sorted.leaves.push_back(s.leaves[i]);
    sorted.values.insert(sorted.values.end(), s.values.begin() + static_cast<std::ptrdiff_t>(i * per),
                         s.values.begin() + static_cast<std::ptrdiff_t>((i + 1) * per));
  }
  s = std::move(sorted);
}

// The P - 1 positions that split the leaves (sorted on each rank) into the counts
// Partition::by_weight gives leaves of weight 1: rank r from leaf ceil(r L / P) on.
tree::Partition equal_count_split(const parallel::Comm& comm, std::span<const CurveCell> sorted, std::int64_t total) {
  const int p = comm.size();
  std::vector<Key> lo(static_cast<std::size_t>(p), 0), hi(static_cast<std::size_t>(p), ~Key{0});
  std::vector<std::int64_t> target(static_cast<std::size_t>(p), 0), below(static_cast<std::size_t>(p));
  for (int r = 1; r < p; ++r)
    target[static_cast<std::size_t>(r)] =
        static_cast<std::int64_t>((static_cast<I128>(r) * total + p - 1) / p);
  const auto count_below = [&](Key s) {
    return static_cast<std::int64_t>(
        std::lower_bound(sorted.begin(), sorted.end(), s, [](const CurveCell& c, Key k) { return c.position < k; }) -
        sorted.begin());
  };
  // The smallest s with (leaves below s) >= target[r]: 64 halvings of the key range.
  for (int round = 0; round < 64; ++round) {
    for (int r = 1; r < p; ++r) {
      const auto u = static_cast<std::size_t>(r);
      below[u] = count_below(lo[u] + (hi[u] - lo[u]) / 2);
    }
    MPI_Allreduce(MPI_IN_PLACE, below.data() + 1, p - 1, MPI_INT64_T, MPI_SUM, comm.handle());
    for (int r = 1; r < p; ++r) {
      const auto u = static_cast<std::size_t>(r);
      const Key mid = lo[u] + (hi[u] - lo[u]) / 2;
      if (below[u] >= target[u]) hi[u] = mid;
      else lo[u] = mid + 1;
    }
  }
  // Each split moved to the first leaf at or after it (a leaf's start: the leaf covering a
  // rank's first position is then its own).
  std::vector<Key> split(static_cast<std::size_t>(p) + 1, ~Key{0});
  for (int r = 1; r < p; ++r) {
    const auto u = static_cast<std::size_t>(r);
    const auto it = std::lower_bound(sorted.begin(), sorted.end(), hi[u],
                                     [](const CurveCell& c, Key k) { return c.position < k; });
    split[u] = it == sorted.end() ? ~Key{0} : it->position;
  }
  MPI_Allreduce(MPI_IN_PLACE, split.data() + 1, p - 1, MPI_UINT64_T, MPI_MIN, comm.handle());
  split[0] = 0;
  return tree::Partition::from_splits(std::move(split));
}

template <int D>
std::string where(const CurveCell& c, int max_level) {
  const tree::Coords<D> ijk = tree::morton_decode<D>(tree::key_of<D>(c, max_level));
  return fmt::format("level {} at ({})", c.level, fmt::join(ijk, ", "));
}

// The leaves (curve order on each rank, ranks in curve order) tile every root once.
template <int D>
void check_tiling(const H5Io& io, const parallel::Comm& comm, const tree::TreeOptions<D>& o,
                  std::span<const CurveCell> leaves, std::int64_t total) {
  const int top = o.max_level;
  const Key root_span = tree::span_of<D>(0, top);
  std::vector<Key> roots;  // the roots' first positions, in curve order
  tree::Coords<D> n{};
  std::int64_t count = 1;
  for (int d = 0; d < D; ++d) count *= o.roots[d];
  for (std::int64_t i = 0; i < count; ++i) {
    std::int64_t rest = i;
    for (int d = 0; d < D; ++d) {
      n[d] = static_cast<std::int32_t>(rest % o.roots[d]);
      rest /= o.roots[d];
    }
    roots.push_back(tree::curve_position<D>(0, tree::morton_encode<D>(n), top));
  }
  std::sort(roots.begin(), roots.end());
  // Where the leaf after one ending at `end` must start (~0: after the last root).
  const auto next_start = [&](Key end) -> Key {
    if (end % root_span != 0) return end;
    const auto it = std::lower_bound(roots.begin(), roots.end(), end);
    return it == roots.end() ? ~Key{0} : *it;
  };
  const auto end_of = [&](const CurveCell& c) { return c.position + tree::span_of<D>(c.level, top); };
  // Every rank's first start and last end (none: ~0 both).
  std::array<Key, 2> mine{~Key{0}, ~Key{0}};
  if (!leaves.empty()) mine = {leaves.front().position, end_of(leaves.back())};
  std::vector<Key> all(2 * static_cast<std::size_t>(comm.size()));
  MPI_Allgather(mine.data(), 2, MPI_UINT64_T, all.data(), 2, MPI_UINT64_T, comm.handle());
  agree(comm, [&] {
    const auto fail = [&](const std::string& what) {
      io.fail(fmt::format("the leaves ({} in the file) do not form a balanced tree on these roots: {}; corrupt "
                          "/tree/keys?",
                          total, what));
    };
    if (leaves.empty()) return;
    // The end of the last leaf of a lower rank, or nothing before this rank's first.
    std::optional<Key> before;
    for (int q = comm.rank() - 1; q >= 0 && !before; --q)
      if (all[2 * static_cast<std::size_t>(q)] != ~Key{0}) before = all[2 * static_cast<std::size_t>(q) + 1];
    const Key first_expected = before ? next_start(*before) : roots.front();
    if (leaves.front().position != first_expected)
      fail(fmt::format("a leaf of {} is not where the curve continues", where<D>(leaves.front(), top)));
    for (std::size_t i = 1; i < leaves.size(); ++i)
      if (leaves[i].position != next_start(end_of(leaves[i - 1])))
        fail(fmt::format("a leaf of {} overlaps or leaves a gap after a leaf of {}", where<D>(leaves[i], top),
                         where<D>(leaves[i - 1], top)));
    bool last = true;
    for (int q = comm.rank() + 1; q < comm.size(); ++q) last = last && all[2 * static_cast<std::size_t>(q)] == ~Key{0};
    if (last && next_start(end_of(leaves.back())) != ~Key{0})
      fail(fmt::format("the domain is not covered after a leaf of {}", where<D>(leaves.back(), top)));
  });
}

// 2:1 balance as Tree::adapt keeps it: the 3^D - 1 neighbours of a leaf's parent are cells
// of the forest (covered by leaves of the parent's level or finer). Checked for one leaf of
// each sibling group; neighbours on other ranks are asked of their owners.
template <int D>
void check_balance(const H5Io& io, const parallel::Comm& comm, const tree::Partition& split,
                   const tree::TreeOptions<D>& o, std::span<const CurveCell> leaves, std::int64_t total) {
  const int top = o.max_level;
  const auto level_at = [&](Key position) {  // the level of the local leaf covering it
    const auto it = std::upper_bound(leaves.begin(), leaves.end(), position,
                                     [](Key k, const CurveCell& c) { return k < c.position; });
    return std::prev(it)->level;
  };
  const auto fail = [&](const CurveCell& leaf, int coarser) {
    io.fail(fmt::format("the leaves ({} in the file) do not form a balanced tree on these roots: a leaf of level {} "
                        "borders the parent of a leaf of {}; corrupt /tree/keys?",
                        total, coarser, where<D>(leaf, top)));
  };
  std::vector<std::vector<std::uint64_t>> ask(static_cast<std::size_t>(comm.size()));
  agree(comm, [&] {
    for (const CurveCell& c : leaves) {
      if (c.level < 2 || (tree::key_of<D>(c, top) & ((Key{1} << D) - 1)) != 0) continue;
      const int m = c.level - 1;
      const tree::Coords<D> parent = tree::morton_decode<D>(tree::key_of<D>(c, top) >> D);
      tree::for_each_stencil_cell<D>(o, m, parent, 1, [&](const CurveCell& n) {
        const int owner = split.owner(n.position);
        if (owner != comm.rank()) {
          auto& w = ask[static_cast<std::size_t>(owner)];
          w.insert(w.end(), {n.position, static_cast<std::uint64_t>(m), c.position, static_cast<std::uint64_t>(c.level)});
        } else if (const int l = level_at(n.position); l < m) {
          fail(c, l);
        }
      });
    }
  });
  const auto asked = parallel::sparse_exchange(comm, ask);
  agree(comm, [&] {
    for (const auto& w : asked)
      for (std::size_t i = 0; i + 3 < w.size(); i += 4)
        if (const int l = level_at(w[i]); l < static_cast<int>(w[i + 1]))
          fail(CurveCell{w[i + 2], static_cast<int>(w[i + 3])}, l);
  });
}

// This rank's rows of the file: their leaves, values, and checksums checked collectively.
template <int D>
Share read_share(const H5Io& io, const parallel::Comm& comm, hid_t root, const tree::Tree<D>& tree,
                 const std::vector<std::int64_t>& leaf_count, std::span<const std::string> leaf_arrays,
                 std::vector<std::size_t>& per_leaf) {
  const std::int64_t total = std::accumulate(leaf_count.begin(), leaf_count.end(), std::int64_t{0});
  const auto p = static_cast<I128>(comm.size());
  const auto r = static_cast<I128>(comm.rank());
  const auto first = static_cast<hsize_t>(r * total / p), last = static_cast<hsize_t>((r + 1) * total / p);
  const detail::RowRun rows{first, last - first};
  Share share;
  std::vector<std::uint64_t> parts, stored;
  std::vector<std::string> names;  // the checksummed datasets, in the order of parts
  per_leaf.assign(leaf_arrays.size(), 0);
  agree(comm, [&] {
    const Handle t = io.group(root, "tree", false);
    const std::vector<hsize_t> shape = io.shape_of(t.get(), "keys", "/tree/keys");
    if (shape.size() != 1 || shape[0] != static_cast<hsize_t>(total))
      io.fail("/tree/leaf_count does not add up to the length of /tree/keys");
    const auto k = io.read_rows<std::uint64_t>(t.get(), "keys", H5T_NATIVE_UINT64, "/tree/keys", rows);
    parts.push_back(k.checksum_part);
    stored.push_back(k.stored_checksum);
    names.emplace_back("/tree/keys");
    // Each row's level from the counts per level.
    std::size_t level = 0;
    std::int64_t level_end = leaf_count[0];
    for (hsize_t i = 0; i < rows.count; ++i) {
      const auto at = static_cast<std::int64_t>(first + i);
      while (at >= level_end) level_end += leaf_count[++level];
      const Key key = k.values[i];
      if (!detail::key_in_grid<D>(tree.options(), static_cast<int>(level), key))
        io.fail(fmt::format("/tree/keys[{}] = {} lies outside the level-{} grid", at, key, level));
      share.leaves.push_back({tree::curve_position<D>(static_cast<int>(level), key, tree.max_level()),
                              static_cast<int>(level)});
    }
  });
  std::vector<std::vector<double>> columns;  // per component, this rank's rows
  agree(comm, [&] {
    const Handle f = io.group(root, "fields", false);
    detail::check_field_names(io, f.get(), tree);
    for (const std::string& name : io.members(f.get(), "/fields")) {
      const std::string path = "/fields/" + name;
      auto a = io.read_rows<double>(f.get(), name, H5T_NATIVE_DOUBLE, path, rows);
      if (a.shape.size() != 1 || a.shape[0] != static_cast<hsize_t>(total))
        io.fail(fmt::format("{} holds {} values for {} leaves", path, a.shape.empty() ? 0 : a.shape[0], total));
      detail::check_finite(io, path, a.values);
      parts.push_back(a.checksum_part);
      stored.push_back(a.stored_checksum);
      names.push_back(path);
      columns.push_back(std::move(a.values));
    }
    const Handle e = io.group(root, "extras", false);
    for (std::size_t x = 0; x < leaf_arrays.size(); ++x) {
      const std::string& name = leaf_arrays[x];
      if (H5Lexists(e.get(), name.c_str(), H5P_DEFAULT) <= 0) continue;  // older files: none
      const std::string path = "/extras/" + name;
      auto a = io.read_rows<double>(e.get(), name, H5T_NATIVE_DOUBLE, path, rows);
      if (a.shape.size() != 2 || a.shape[0] != static_cast<hsize_t>(total) || a.shape[1] == 0)
        io.fail(fmt::format("{} is not one row per leaf ({} leaves)", path, total));
      detail::check_finite(io, path, a.values);
      parts.push_back(a.checksum_part);
      stored.push_back(a.stored_checksum);
      names.push_back(path);
      per_leaf[x] = static_cast<std::size_t>(a.shape[1]);
      for (std::size_t c = 0; c < per_leaf[x]; ++c) {
        std::vector<double> column(rows.count);
        for (hsize_t i = 0; i < rows.count; ++i) column[i] = a.values[i * per_leaf[x] + c];
        columns.push_back(std::move(column));
      }
    }
  });
  // Unsigned sums wrap: the terms of every rank add up to the writer's sum mod 2^64.
  std::vector<std::uint64_t> sums(parts.size());
  MPI_Allreduce(parts.data(), sums.data(), static_cast<int>(parts.size()), MPI_UINT64_T, MPI_SUM, comm.handle());
  agree(comm, [&] {
    for (std::size_t i = 0; i < sums.size(); ++i)
      if (sums[i] != stored[i]) io.fail(fmt::format("dataset {} fails its checksum: the file is corrupt", names[i]));
  });
  share.components = std::max<int>(1, static_cast<int>(columns.size()));
  share.values.assign(share.leaves.size() * static_cast<std::size_t>(share.components), 0.0);
  for (std::size_t c = 0; c < columns.size(); ++c)
    for (std::size_t i = 0; i < share.leaves.size(); ++i) share.values[i * columns.size() + c] = columns[c][i];
  return share;
}

// A version 1 or 2 file: its checksums chain through every byte in order, so every rank
// reads it whole and keeps its part (tree::distribute).
template <int D>
DistributedRestart<D> read_whole(const parallel::Comm& comm, const std::filesystem::path& path, tree::Tree<D>& tree,
                                 const CheckpointExpectations& expect, std::span<const std::string> leaf_arrays) {
  DistributedRestart<D> out;
  agree(comm, [&] { out.state = read_checkpoint(path, tree, expect); });
  std::vector<std::pair<int, Key>> file_order;  // (level, key), the file's rows
  for (const tree::Index c : tree.leaves()) {
    const int l = tree.level_of(c);
    file_order.emplace_back(l, tree.level(l).keys[static_cast<std::size_t>(c - tree.level(l).base)]);
  }
  std::sort(file_order.begin(), file_order.end());
  out.forest = tree::distribute(comm, tree);
  const std::vector<tree::Index> mine = tree::owned_leaves_by_key(tree);
  for (const std::string& name : leaf_arrays) {
    const auto it = std::find_if(out.state.extras.begin(), out.state.extras.end(),
                                 [&](const ExtraArray& e) { return e.name == name; });
    if (it == out.state.extras.end()) continue;
    agree(comm, [&] {
      if (it->shape.size() != 2 || it->shape[0] != file_order.size() || it->shape[1] == 0)
        throw CheckpointError(fmt::format("{}: /extras/{} is not one row per leaf", path.string(), name));
    });
    LeafArray a{.name = name, .per_leaf = it->shape[1], .values = {}};
    for (const tree::Index c : mine) {
      const int l = tree.level_of(c);
      const std::pair<int, Key> key{l, tree.level(l).keys[static_cast<std::size_t>(c - tree.level(l).base)]};
      const auto row = static_cast<std::size_t>(std::lower_bound(file_order.begin(), file_order.end(), key) - file_order.begin());
      a.values.insert(a.values.end(), it->values.begin() + static_cast<std::ptrdiff_t>(row * a.per_leaf),
                      it->values.begin() + static_cast<std::ptrdiff_t>((row + 1) * a.per_leaf));
    }
    out.leaf_arrays.push_back(std::move(a));
    out.state.extras.erase(it);
  }
  return out;
}

}  // namespace

template <int D>
DistributedRestart<D> read_checkpoint_distributed(const parallel::Comm& comm, const std::filesystem::path& path,
                                                  tree::Tree<D>& tree, const CheckpointExpectations& expect,
                                                  std::span<const std::string> leaf_arrays) {
  if (tree.depth() != 0)
    throw std::invalid_argument("read_checkpoint: the tree must be its bare roots (build it from the case)");
  if (!comm.distributed()) throw std::invalid_argument("read_checkpoint_distributed: one rank reads with read_checkpoint");
  const detail::QuietErrors quiet;
  H5Io io(path.string(), H5Io::Mode::read);
  std::optional<detail::CheckpointHeader> header;
  agree(comm, [&] { header = detail::read_header(io, path, tree); });
  if (header->version < 3) {
    header.reset();
    return read_whole(comm, path, tree, expect, leaf_arrays);
  }
  DistributedRestart<D> out;
  const hid_t root = header->file.get();
  const std::int64_t total = std::accumulate(header->leaf_count.begin(), header->leaf_count.end(), std::int64_t{0});
  // The file's order of checks: the leaf keys, the scalars and extras, the fields.
  std::vector<std::size_t> per_leaf;
  agree(comm, [&] { out.state = detail::read_scalars_and_extras(io, root, expect, leaf_arrays); });
  Share share = read_share(io, comm, root, tree, header->leaf_count, leaf_arrays, per_leaf);
  header.reset();  // the file is closed: what follows is the ranks' own

  // Curve order across the ranks, then the checks of the leaf set.
  sort_share(share);
  const tree::Partition split = equal_count_split(comm, share.leaves, total);
  tree::MigratedLeaves moved = tree::migrate_leaves(comm, split, share.leaves, share.values, share.components);
  share.leaves = std::move(moved.leaves);
  share.values = std::move(moved.values);
  sort_share(share);
  check_tiling<D>(io, comm, tree.options(), share.leaves, total);
  check_balance<D>(io, comm, split, tree.options(), share.leaves, total);

  // The partition tree::distribute makes (every leaf weighs 1), and the local tree.
  std::vector<Key> positions(share.leaves.size());
  for (std::size_t i = 0; i < positions.size(); ++i) positions[i] = share.leaves[i].position;
  const tree::Partition partition =
      tree::Partition::by_weight(comm, positions, std::vector<std::int64_t>(positions.size(), 1));
  moved = tree::migrate_leaves(comm, partition, share.leaves, share.values, share.components);
  out.forest = std::make_unique<tree::DistributedForest<D>>(comm, partition, tree.options(), moved.leaves);
  tree::Tree<D> local = out.forest->make_tree();
  for (int f = 0; f < tree.num_fields(); ++f) (void)local.add_field(tree.field_spec(f));
  tree = std::move(local);
  out.forest->attach(tree);

  // The values: saved fields in name order, then the per-leaf extras.
  std::vector<std::pair<std::string, tree::FieldId>> saved;
  for (tree::FieldId f = 0; f < tree.num_fields(); ++f)
    if (tree.field_spec(f).saved) saved.emplace_back(tree.field_spec(f).name, f);
  std::sort(saved.begin(), saved.end());
  const auto per = static_cast<std::size_t>(share.components);
  std::vector<tree::Index> cells(moved.leaves.size());
  for (std::size_t i = 0; i < moved.leaves.size(); ++i) {
    const CurveCell& c = moved.leaves[i];
    cells[i] = tree.find(c.level, tree::morton_decode<D>(tree::key_of<D>(c, tree.max_level())));
    for (std::size_t k = 0; k < saved.size(); ++k)
      tree.values(saved[k].second)[static_cast<std::size_t>(cells[i])] = moved.values[i * per + k];
  }
  for (const auto& [name, f] : saved) {
    if (tree.field_spec(f).prolongation != tree::Prolongation::none) tree.sync(f);
    else tree.update_ghosts(tree.values(f));
  }
  // The per-leaf extras, rows of this rank's leaves by (level, key) (LeafArray's order).
  const std::vector<tree::Index> by_key = tree::owned_leaves_by_key(tree);
  std::vector<std::size_t> row_of_cell;  // moved row of each by_key leaf
  {
    std::vector<std::pair<tree::Index, std::size_t>> at(cells.size());
    for (std::size_t i = 0; i < cells.size(); ++i) at[i] = {cells[i], i};
    std::sort(at.begin(), at.end());
    for (const tree::Index c : by_key)
      row_of_cell.push_back(std::lower_bound(at.begin(), at.end(), std::pair<tree::Index, std::size_t>{c, 0})->second);
  }
  std::size_t column = saved.size();
  for (std::size_t x = 0; x < leaf_arrays.size(); ++x) {
    if (per_leaf[x] == 0) continue;
    LeafArray a{.name = leaf_arrays[x], .per_leaf = per_leaf[x], .values = {}};
    a.values.reserve(by_key.size() * per_leaf[x]);
    for (const std::size_t i : row_of_cell)
      for (std::size_t c = 0; c < per_leaf[x]; ++c) a.values.push_back(moved.values[i * per + column + c]);
    column += per_leaf[x];
    out.leaf_arrays.push_back(std::move(a));
  }
  return out;
}

template DistributedRestart<2> read_checkpoint_distributed<2>(const parallel::Comm&, const std::filesystem::path&,
                                                              tree::Tree<2>&, const CheckpointExpectations&,
                                                              std::span<const std::string>);
template DistributedRestart<3> read_checkpoint_distributed<3>(const parallel::Comm&, const std::filesystem::path&,
                                                              tree::Tree<3>&, const CheckpointExpectations&,
                                                              std::span<const std::string>);

}  // namespace capsflow::io
