// Checkpoint writer; the layout is docs/checkpoint-format.md.
#include <fmt/format.h>

#include <algorithm>
#include <set>
#include <stdexcept>

#include "io/atomic_write.hpp"
#include "io/checkpoint.hpp"
#include "io/h5_file.hpp"

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

}  // namespace

template <int D>
void write_checkpoint(const std::filesystem::path& path, const tree::Tree<D>& tree,
                      const CheckpointScalars& scalars, std::span<const ExtraArray> extras) {
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
    if (n != e.values.size())
      throw std::invalid_argument(fmt::format("write_checkpoint: extra \"{}\" has {} values for its shape ({} expected)",
                                              e.name, e.values.size(), n));
  }
  check_names(field_names, "field");
  check_names(extra_names, "extra");

  // The leaf set, level by level in Tree::leaves() order, and the leaf values in that order.
  const std::span<const tree::Index> leaves = tree.leaves();
  std::vector<std::int64_t> leaf_count(static_cast<std::size_t>(tree.depth() + 1), 0);
  std::vector<std::uint64_t> keys;
  keys.reserve(leaves.size());
  for (const tree::Index c : leaves) {
    const int l = tree.level_of(c);
    ++leaf_count[static_cast<std::size_t>(l)];
    keys.push_back(tree.level(l).keys[static_cast<std::size_t>(c - tree.level(l).base)]);
  }
  const hsize_t n = leaves.size();

  atomic_write(path, [&](const std::filesystem::path& tmp) {
    const detail::QuietErrors quiet;
    const detail::H5Io io(path.string(), detail::H5Io::Mode::write);
    const detail::Handle fapl = detail::checksummed_file_access();
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
    io.write(t.get(), "keys", H5T_NATIVE_UINT64, {n}, keys.data());

    const detail::Handle f = io.group(root, "fields", true);
    std::vector<double> values(leaves.size());
    for (std::size_t k = 0; k < saved.size(); ++k) {
      const std::span<const double> v = tree.values(saved[k]);
      for (std::size_t i = 0; i < leaves.size(); ++i) values[i] = v[leaves[i]];
      io.write(f.get(), field_names[k], H5T_NATIVE_DOUBLE, {n}, values.data());
    }

    const detail::Handle e = io.group(root, "extras", true);
    for (const ExtraArray& x : extras) {
      const std::vector<hsize_t> shape(x.shape.begin(), x.shape.end());
      io.write(e.get(), x.name, H5T_NATIVE_DOUBLE, shape, x.values.data());
    }
  });
}

template void write_checkpoint<2>(const std::filesystem::path&, const tree::Tree<2>&, const CheckpointScalars&,
                                  std::span<const ExtraArray>);
template void write_checkpoint<3>(const std::filesystem::path&, const tree::Tree<3>&, const CheckpointScalars&,
                                  std::span<const ExtraArray>);

}  // namespace capsflow::io
