#include "io/h5_file.hpp"

#include <fmt/format.h>

#include <stdexcept>

#include "io/errors.hpp"

namespace capsflow::io::detail {

void H5Io::fail(const std::string& what) const {
  const std::string msg = fmt::format("{}: {}", file_, what);
  if (mode_ == Mode::read) throw CheckpointError(msg);
  throw std::runtime_error(msg);
}

Handle H5Io::group(hid_t loc, const std::string& name, bool create) const {
  const hid_t id = create ? H5Gcreate2(loc, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT)
                          : (H5Lexists(loc, name.c_str(), H5P_DEFAULT) > 0
                                 ? H5Gopen2(loc, name.c_str(), H5P_DEFAULT)
                                 : H5I_INVALID_HID);
  if (id < 0) fail(fmt::format("{} group /{}", create ? "cannot create" : "missing", name));
  return {id, H5Gclose};
}

namespace {
Handle dataspace(const std::vector<hsize_t>& shape) {
  return {shape.empty() ? H5Screate(H5S_SCALAR)
                        : H5Screate_simple(static_cast<int>(shape.size()), shape.data(), nullptr),
          H5Sclose};
}
}  // namespace

void H5Io::write(hid_t loc, const std::string& name, hid_t type, const std::vector<hsize_t>& shape,
                 const void* data) const {
  const Handle space = dataspace(shape);
  const Handle set(H5Dcreate2(loc, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                   H5Dclose);
  if (!set.valid() || H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(fmt::format("cannot write dataset {}", name));
}

void H5Io::attribute(hid_t loc, const std::string& name, hid_t type, const std::vector<hsize_t>& shape,
                     const void* data) const {
  const Handle space = dataspace(shape);
  const Handle attr(H5Acreate2(loc, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.valid() || H5Awrite(attr.get(), type, data) < 0)
    fail(fmt::format("cannot write attribute {}", name));
}

void H5Io::string_attribute(hid_t loc, const std::string& name, const std::string& value) const {
  const Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), value.size());
  H5Tset_strpad(type.get(), H5T_STR_NULLPAD);
  attribute(loc, name, type.get(), {}, value.data());
}

namespace {

// Takes ownership of a dataspace; sizes `a` (shape and values) from it. False if the
// dataspace is unreadable.
template <class T>
bool sized_from(hid_t space_id, Array<T>& a) {
  const Handle space(space_id, H5Sclose);
  if (!space.valid()) return false;
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) return false;
  a.shape.resize(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space.get(), a.shape.data(), nullptr);
  std::size_t n = 1;
  for (const hsize_t d : a.shape) n *= d;
  a.values.resize(n);
  return true;
}

}  // namespace

template <class T>
Array<T> H5Io::read(hid_t loc, const std::string& name, hid_t type, const std::string& path) const {
  if (H5Lexists(loc, name.c_str(), H5P_DEFAULT) <= 0) fail(fmt::format("missing dataset {}", path));
  const Handle set(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.valid()) fail(fmt::format("{} is not a readable dataset", path));
  Array<T> a;
  if (!sized_from(H5Dget_space(set.get()), a)) fail(fmt::format("{}: unreadable shape", path));
  if (!a.values.empty() && H5Dread(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.values.data()) < 0)
    fail(fmt::format("cannot read dataset {} (corrupt file?)", path));
  return a;
}

template <class T>
Array<T> H5Io::read_attribute(hid_t loc, const std::string& name, hid_t type, const std::string& path) const {
  if (H5Aexists(loc, name.c_str()) <= 0) fail(fmt::format("missing attribute {}", path));
  const Handle attr(H5Aopen(loc, name.c_str(), H5P_DEFAULT), H5Aclose);
  Array<T> a;
  if (!attr.valid() || !sized_from(H5Aget_space(attr.get()), a))
    fail(fmt::format("{} is not a readable attribute", path));
  if (H5Aread(attr.get(), type, a.values.data()) < 0) fail(fmt::format("cannot read attribute {}", path));
  return a;
}

std::string H5Io::read_string_attribute(hid_t loc, const std::string& name, const std::string& path) const {
  if (H5Aexists(loc, name.c_str()) <= 0) fail(fmt::format("missing attribute {}", path));
  const Handle attr(H5Aopen(loc, name.c_str(), H5P_DEFAULT), H5Aclose);
  const Handle type(H5Aget_type(attr.get()), H5Tclose);
  if (!attr.valid() || !type.valid() || H5Tget_class(type.get()) != H5T_STRING || H5Tis_variable_str(type.get()) > 0)
    fail(fmt::format("{} is not a fixed-length string", path));
  std::string s(H5Tget_size(type.get()), '\0');
  if (H5Aread(attr.get(), type.get(), s.data()) < 0) fail(fmt::format("cannot read attribute {}", path));
  s.erase(s.find_last_not_of('\0') + 1);
  return s;
}

std::vector<std::string> H5Io::members(hid_t group, const std::string& path) const {
  H5G_info_t info;
  if (H5Gget_info(group, &info) < 0) fail(fmt::format("cannot list group {}", path));
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t len = H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (len < 0) fail(fmt::format("cannot list group {}", path));
    std::string name(static_cast<std::size_t>(len) + 1, '\0');
    H5Lget_name_by_idx(group, ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(), name.size(), H5P_DEFAULT);
    name.resize(static_cast<std::size_t>(len));
    names.push_back(std::move(name));
  }
  return names;
}

template Array<double> H5Io::read<double>(hid_t, const std::string&, hid_t, const std::string&) const;
template Array<std::int64_t> H5Io::read<std::int64_t>(hid_t, const std::string&, hid_t, const std::string&) const;
template Array<std::uint64_t> H5Io::read<std::uint64_t>(hid_t, const std::string&, hid_t, const std::string&) const;
template Array<double> H5Io::read_attribute<double>(hid_t, const std::string&, hid_t, const std::string&) const;
template Array<std::int32_t> H5Io::read_attribute<std::int32_t>(hid_t, const std::string&, hid_t,
                                                                const std::string&) const;

}  // namespace capsflow::io::detail
