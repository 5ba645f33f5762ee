// The checks every checkpoint reader makes first (checkpoint_header.hpp).
#include "io/checkpoint_header.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>

#include "io/checkpoint_values.hpp"

namespace capsflow::io::detail {

namespace {

template <class T>
T scalar(const Array<T>& a, const H5Io& io, const std::string& path) {
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

}  // namespace

template <int D>
CheckpointHeader read_header(H5Io& io, const std::filesystem::path& path, const tree::Tree<D>& tree) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) io.fail("no such checkpoint file");
  CheckpointHeader h;
  h.file = Handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!h.file.valid())
    io.fail(error_stack_mentions_checksum() ? "not a readable HDF5 file (checksum mismatch: corrupt)"
                                            : "not a readable HDF5 file (truncated or corrupt?)");
  const hid_t root = h.file.get();
  if (H5Aexists(root, "format") <= 0 || io.read_string_attribute(root, "format", "/@format") != kCheckpointFormat)
    io.fail("not a capsflow checkpoint (no /@format = \"capsflow checkpoint\")");
  h.version = scalar(io.read_attribute<std::int32_t>(root, "format_version", H5T_NATIVE_INT32, "/@format_version"),
                     io, "/@format_version");
  if (h.version < kOldestCheckpointVersion || h.version > kCheckpointVersion)
    io.fail(fmt::format("checkpoint format version {}, this capsflow reads versions {} to {}", h.version,
                        kOldestCheckpointVersion, kCheckpointVersion));
  io.expect_format_version(h.version);
  const auto dim = scalar(io.read_attribute<std::int32_t>(root, "dimension", H5T_NATIVE_INT32, "/@dimension"),
                          io, "/@dimension");
  if (dim != D) io.fail(fmt::format("written by a {}D run, this run is {}D", dim, D));
  const Handle t = io.group(root, "tree", false);
  check_options<D>(io, t.get(), tree.options());
  const auto count = io.read<std::int64_t>(t.get(), "leaf_count", H5T_NATIVE_INT64, "/tree/leaf_count");
  if (count.shape.size() != 1 || count.values.empty())
    io.fail("/tree/leaf_count and /tree/keys must be one-dimensional and non-empty");
  const int depth = static_cast<int>(count.values.size()) - 1;
  if (depth > tree.max_level())
    io.fail(fmt::format("leaves at level {}, deeper than adapt.max_level = {} of this run", depth, tree.max_level()));
  for (const std::int64_t n : count.values)
    if (n < 0) io.fail("/tree/leaf_count does not add up to the length of /tree/keys");
  h.leaf_count = count.values;
  return h;
}

RestoredState read_scalars_and_extras(const H5Io& io, hid_t root, const CheckpointExpectations& expect,
                                      std::span<const std::string> leaf_arrays) {
  RestoredState state;
  const Handle s = io.group(root, "scalars", false);
  state.scalars.time = scalar(io.read<double>(s.get(), "time", H5T_NATIVE_DOUBLE, "/scalars/time"), io, "/scalars/time");
  state.scalars.step = scalar(io.read<std::int64_t>(s.get(), "step", H5T_NATIVE_INT64, "/scalars/step"), io, "/scalars/step");
  state.scalars.dt = scalar(io.read<double>(s.get(), "dt", H5T_NATIVE_DOUBLE, "/scalars/dt"), io, "/scalars/dt");
  check_scalars(io, state.scalars, expect);
  const Handle e = io.group(root, "extras", false);
  for (const std::string& name : io.members(e.get(), "/extras")) {
    if (std::find(leaf_arrays.begin(), leaf_arrays.end(), name) != leaf_arrays.end()) continue;
    auto a = io.read<double>(e.get(), name, H5T_NATIVE_DOUBLE, "/extras/" + name);
    check_finite(io, "/extras/" + name, a.values);
    state.extras.push_back({.name = name,
                            .shape = std::vector<std::size_t>(a.shape.begin(), a.shape.end()),
                            .values = std::move(a.values)});
  }
  check_capsules(io, state.extras, expect);
  return state;
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

template CheckpointHeader read_header<2>(H5Io&, const std::filesystem::path&, const tree::Tree<2>&);
template CheckpointHeader read_header<3>(H5Io&, const std::filesystem::path&, const tree::Tree<3>&);
template void check_field_names<2>(const H5Io&, hid_t, const tree::Tree<2>&);
template void check_field_names<3>(const H5Io&, hid_t, const tree::Tree<3>&);

}  // namespace capsflow::io::detail
