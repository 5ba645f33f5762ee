// Checkpoint writer; the layout is docs/checkpoint-format.md.
#include <fmt/format.h>

#include <algorithm>
#include <functional>
#include <set>
#include <stdexcept>

#include "io/atomic_write.hpp"
#include "io/checkpoint.hpp"
#include "io/h5_file.hpp"
#include "parallel/all_or_none.hpp"
#include "tree/distributed_forest.hpp"
#include "tree/leaf_order.hpp"

namespace capsflow::io {

namespace {

void check_names(std::span<const std::string> names, std::string_view kind) {
  std::set<std::string_view> seen;
  for (const std::string& n : names) {
    if (n.empty() || n.find('/') != std::string::npos || n == "." )
      throw std::invalid_argument(fmt::format("write_checkpoint: bad {} name \"{}\"", kind, n));
    if (!seen.insert(n).second)
      throw std::invalid_argument(fmt::format("write_checkpoint: two {}s named \"{}\"", kind, n));
  }
}

// The ranks of a distributed tree (nullptr on one rank).
template <int D>
const parallel::Comm* ranks_of(const tree::Tree<D>& tree) {
  const auto* forest = dynamic_cast<const tree::DistributedForest<D>*>(tree.distribution());
  return forest && forest->comm().distributed() ? &forest->comm() : nullptr;
}

// Rank 0's extras on every rank: names and shapes (every rank creates every dataset); the
// values stay on rank 0, the only writer.
std::vector<ExtraArray> shapes_from_root(MPI_Comm comm, std::span<const ExtraArray> extras) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  std::vector<std::uint64_t> words;  // count, then per extra: name length, name bytes, dims, shape
  if (rank == 0) {
    words.push_back(extras.size());
    for (const ExtraArray& e : extras) {
      words.push_back(e.name.size());
      for (const char ch : e.name) words.push_back(static_cast<unsigned char>(ch));
      words.push_back(e.shape.size());
      for (const std::size_t d : e.shape) words.push_back(d);
    }
  }
  std::uint64_t size = words.size();
  MPI_Bcast(&size, 1, MPI_UINT64_T, 0, comm);
  words.resize(static_cast<std::size_t>(size));
  MPI_Bcast(words.data(), static_cast<int>(size), MPI_UINT64_T, 0, comm);
  if (rank == 0) return {extras.begin(), extras.end()};
  std::vector<ExtraArray> out(static_cast<std::size_t>(words[0]));
  std::size_t at = 1;
  for (ExtraArray& e : out) {
    e.name.resize(static_cast<std::size_t>(words[at++]));
    for (char& ch : e.name) ch = static_cast<char>(words[at++]);
    e.shape.resize(static_cast<std::size_t>(words[at++]));
    for (std::size_t& d : e.shape) d = static_cast<std::size_t>(words[at++]);
  }
  return out;
}

// The same temporary name on every rank: rank 0's.
std::string shared_string(MPI_Comm comm, std::string s) {
  std::uint64_t size = s.size();
  MPI_Bcast(&size, 1, MPI_UINT64_T, 0, comm);
  s.resize(static_cast<std::size_t>(size));
  MPI_Bcast(s.data(), static_cast<int>(size), MPI_CHAR, 0, comm);
  return s;
}

}  // namespace

template <int D>
void write_checkpoint(const std::filesystem::path& path, const tree::Tree<D>& tree,
                      const CheckpointScalars& scalars, std::span<const ExtraArray> root_extras,
                      std::span<const LeafArray> leaf_arrays) {
  const parallel::Comm* ranks = ranks_of(tree);
  const MPI_Comm comm = ranks ? ranks->handle() : MPI_COMM_NULL;
  const int rank = ranks ? ranks->rank() : 0;
  const std::vector<ExtraArray> extras =
      comm == MPI_COMM_NULL ? std::vector<ExtraArray>(root_extras.begin(), root_extras.end())
                            : shapes_from_root(comm, root_extras);
  std::vector<std::string> field_names, extra_names;
  std::vector<tree::FieldId> saved;  // fields a checkpoint keeps
  for (tree::FieldId f = 0; f < tree.num_fields(); ++f)
    if (tree.field_spec(f).saved) {
      field_names.push_back(tree.field_spec(f).name);
      saved.push_back(f);
    }
  for (const ExtraArray& e : extras) {
    extra_names.push_back(e.name);
    std::size_t n = 1;
    for (const std::size_t s : e.shape) n *= s;
    if (rank == 0 && n != e.values.size())
      throw std::invalid_argument(fmt::format("write_checkpoint: extra \"{}\" has {} values for its shape ({} expected)",
                                              e.name, e.values.size(), n));
  }
  for (const LeafArray& a : leaf_arrays) extra_names.push_back(a.name);
  check_names(field_names, "field");
  check_names(extra_names, "extra");

  // This rank's leaves by (level, key): per level one run of the file's rows, after the runs
  // of the lower ranks (tree/leaf_order.hpp).
  const std::vector<tree::Index> leaves = tree::owned_leaves_by_key(tree);
  const int top = tree.options().max_level;
  std::vector<std::int64_t> mine(static_cast<std::size_t>(top) + 1, 0), below(mine.size(), 0), total(mine.size(), 0);
  std::vector<std::uint64_t> keys;
  keys.reserve(leaves.size());
  for (const tree::Index c : leaves) {
    const int l = tree.level_of(c);
    ++mine[static_cast<std::size_t>(l)];
    keys.push_back(tree.level(l).keys[static_cast<std::size_t>(c - tree.level(l).base)]);
  }
  const int levels = static_cast<int>(mine.size());
  if (comm == MPI_COMM_NULL) {
    total = mine;
  } else {
    MPI_Allreduce(mine.data(), total.data(), levels, MPI_INT64_T, MPI_SUM, comm);
    MPI_Exscan(mine.data(), below.data(), levels, MPI_INT64_T, MPI_SUM, comm);
    if (rank == 0) std::fill(below.begin(), below.end(), 0);  // MPI_Exscan leaves rank 0's undefined
  }
  int depth = 0;  // the deepest level holding leaves (the tree's depth)
  for (int l = 0; l < levels; ++l)
    if (total[static_cast<std::size_t>(l)] > 0) depth = l;
  const std::vector<std::int64_t> leaf_count(total.begin(), total.begin() + depth + 1);
  std::vector<detail::RowRun> runs;
  hsize_t n = 0;
  for (int l = 0; l <= depth; ++l) {
    const auto u = static_cast<std::size_t>(l);
    runs.push_back({n + static_cast<hsize_t>(below[u]), static_cast<hsize_t>(mine[u])});
    n += static_cast<hsize_t>(total[u]);
  }
  for (const LeafArray& a : leaf_arrays)
    if (a.per_leaf == 0 || a.values.size() != leaves.size() * a.per_leaf)
      throw std::invalid_argument(fmt::format("write_checkpoint: leaf array \"{}\" has {} values for {} leaves of {}",
                                              a.name, a.values.size(), leaves.size(), a.per_leaf));

  const auto write_file = [&](const std::filesystem::path& tmp) {
    const detail::QuietErrors quiet;
    const detail::H5Io io(path.string(), detail::H5Io::Mode::write, comm);
    const detail::Handle fapl =
        comm == MPI_COMM_NULL ? detail::checksummed_file_access() : detail::mpio_file_access(comm);
    const detail::Handle file(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl.get()), H5Fclose);
    if (!file.valid()) io.fail("cannot create the file");
    const hid_t root = file.get();
    io.string_attribute(root, "format", detail::kCheckpointFormat);
    const std::int32_t version = detail::kCheckpointVersion, dim = D;
    io.attribute(root, "format_version", H5T_NATIVE_INT32, {}, &version);
    io.attribute(root, "dimension", H5T_NATIVE_INT32, {}, &dim);

    const detail::Handle s = io.group(root, "scalars", true);
    io.write(s.get(), "time", H5T_NATIVE_DOUBLE, {}, &scalars.time);
    io.write(s.get(), "step", H5T_NATIVE_INT64, {}, &scalars.step);
    io.write(s.get(), "dt", H5T_NATIVE_DOUBLE, {}, &scalars.dt);

    const tree::TreeOptions<D>& o = tree.options();
    const detail::Handle t = io.group(root, "tree", true);
    std::array<std::int32_t, D> roots{}, periodic{};
    for (int d = 0; d < D; ++d) {
      roots[d] = o.roots[d];
      periodic[d] = o.periodic[d] ? 1 : 0;
    }
    const std::int32_t max_level = o.max_level;
    io.attribute(t.get(), "roots", H5T_NATIVE_INT32, {D}, roots.data());
    io.attribute(t.get(), "root_size", H5T_NATIVE_DOUBLE, {}, &o.root_size);
    io.attribute(t.get(), "origin", H5T_NATIVE_DOUBLE, {D}, o.origin.data());
    io.attribute(t.get(), "periodic", H5T_NATIVE_INT32, {D}, periodic.data());
    io.attribute(t.get(), "max_level", H5T_NATIVE_INT32, {}, &max_level);
    io.write(t.get(), "leaf_count", H5T_NATIVE_INT64, {leaf_count.size()}, leaf_count.data());
    io.write_rows(t.get(), "keys", H5T_NATIVE_UINT64, {n}, runs, keys.data());

    const detail::Handle f = io.group(root, "fields", true);
    std::vector<double> values(leaves.size());
    for (std::size_t k = 0; k < saved.size(); ++k) {
      const std::span<const double> v = tree.values(saved[k]);
      for (std::size_t i = 0; i < leaves.size(); ++i) values[i] = v[static_cast<std::size_t>(leaves[i])];
      io.write_rows(f.get(), field_names[k], H5T_NATIVE_DOUBLE, {n}, runs, values.data());
    }

    const detail::Handle e = io.group(root, "extras", true);
    // Every extra in name order, as HDF5 lists them (the same on every rank).
    std::vector<std::pair<std::string, std::function<void()>>> writes;
    for (const ExtraArray& x : extras)
      writes.emplace_back(x.name, [&] {
        const std::vector<hsize_t> shape(x.shape.begin(), x.shape.end());
        io.write(e.get(), x.name, H5T_NATIVE_DOUBLE, shape, x.values.data());
      });
    for (const LeafArray& a : leaf_arrays)
      writes.emplace_back(a.name, [&] {
        io.write_rows(e.get(), a.name, H5T_NATIVE_DOUBLE, {n, static_cast<hsize_t>(a.per_leaf)}, runs, a.values.data());
      });
    std::sort(writes.begin(), writes.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& w : writes) w.second();
  };

  if (comm == MPI_COMM_NULL) {
    atomic_write(path, write_file);
    return;
  }
  // N ranks: one temporary, written by all; rank 0 renames it once every rank has closed it.
  const std::string tmp = shared_string(comm, temporary_path_for(path).string());
  try {
    parallel::all_or_none(*ranks, [&] { write_file(tmp); });
  } catch (...) {
    if (rank == 0) {
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
    }
    throw;
  }
  parallel::all_or_none(*ranks, [&] {
    if (rank == 0) commit_temporary(tmp, path);
  });
}

template void write_checkpoint<2>(const std::filesystem::path&, const tree::Tree<2>&, const CheckpointScalars&,
                                  std::span<const ExtraArray>, std::span<const LeafArray>);
template void write_checkpoint<3>(const std::filesystem::path&, const tree::Tree<3>&, const CheckpointScalars&,
                                  std::span<const ExtraArray>, std::span<const LeafArray>);

}  // namespace capsflow::io
