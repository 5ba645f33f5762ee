#include "io/h5_file.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <limits>
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

std::uint64_t fnv_checksum(const void* data, std::size_t values, std::size_t value_bytes) {
  std::uint64_t h = 14695981039346656037ull;
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t v = 0; v < values; ++v)
    for (std::size_t b = 0; b < value_bytes; ++b) {
      const std::size_t at = std::endian::native == std::endian::little ? b : value_bytes - 1 - b;
      h = (h ^ bytes[v * value_bytes + at]) * 1099511628211ull;
    }
  return h;
}

namespace {
// SplitMix64's finaliser (Steele, Lea & Flood 2014): every input bit changes about half of the
// output bits, so a zeroed, swapped or flipped value changes its term unpredictably.
std::uint64_t splitmix(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
}  // namespace

std::uint64_t indexed_checksum(const void* data, std::size_t values, std::uint64_t first_index) {
  std::uint64_t sum = 0;
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t v = 0; v < values; ++v) {
    std::uint64_t word = 0;
    std::memcpy(&word, bytes + 8 * v, 8);
    if constexpr (std::endian::native == std::endian::big) word = __builtin_bswap64(word);
    sum += splitmix(word + splitmix(first_index + v));
  }
  return sum;
}

namespace {
constexpr char kChecksumAttribute[] = "checksum";

// Chunks of at most 64 Ki values (512 KiB of doubles): each carries its own checksum, and
// one fits HDF5's default 1 MiB chunk cache.
std::vector<hsize_t> chunk_shape(const std::vector<hsize_t>& shape) {
  constexpr hsize_t kMaxValues = hsize_t{1} << 16;
  std::vector<hsize_t> chunk = shape;
  hsize_t rest = 1;
  for (std::size_t i = 1; i < chunk.size(); ++i) rest *= chunk[i];
  chunk[0] = std::clamp<hsize_t>(kMaxValues / std::max<hsize_t>(rest, 1), 1, chunk[0]);
  return chunk;
}
}  // namespace

void H5Io::write(hid_t loc, const std::string& name, hid_t type, const std::vector<hsize_t>& shape,
                 const void* data) const {
  int rank = 0;
  if (comm_ != MPI_COMM_NULL) MPI_Comm_rank(comm_, &rank);
  if (!shape.empty()) {
    std::vector<RowRun> runs;
    if (rank == 0 && shape[0] > 0) runs.push_back({0, shape[0]});
    write_rows(loc, name, type, shape, runs, data);
    return;
  }
  // A scalar lives in its (checksummed) object header; every process writes the same value.
  if (H5Tget_size(type) != 8) fail(fmt::format("dataset {}: checksums cover 8-byte values only", name));
  const Handle space = dataspace(shape);
  const Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  const bool ok = dcpl.valid() && H5Pset_layout(dcpl.get(), H5D_COMPACT) >= 0;
  const Handle set(ok ? H5Dcreate2(loc, name.c_str(), type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT)
                      : H5I_INVALID_HID,
                   H5Dclose);
  if (!set.valid() || H5Dwrite(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(fmt::format("cannot write dataset {}", name));
  const std::uint64_t sum = indexed_checksum(data, 1, 0);
  attribute(set.get(), kChecksumAttribute, H5T_NATIVE_UINT64, {}, &sum);
}

void H5Io::write_rows(hid_t loc, const std::string& name, hid_t type, const std::vector<hsize_t>& shape,
                      const std::vector<RowRun>& runs, const void* local) const {
  if (shape.empty() || H5Tget_size(type) != 8) fail(fmt::format("dataset {}: rows of 8-byte values expected", name));
  hsize_t n = 1, per_row = 1;
  for (const hsize_t d : shape) n *= d;
  for (std::size_t i = 1; i < shape.size(); ++i) per_row *= shape[i];
  const Handle space = dataspace(shape);
  const Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  bool ok = dcpl.valid();
  if (n > 0) {  // (an empty array has no values to protect)
    const std::vector<hsize_t> chunk = chunk_shape(shape);
    ok = ok && H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()) >= 0 &&
         H5Pset_fletcher32(dcpl.get()) >= 0;
  }
  const Handle set(ok ? H5Dcreate2(loc, name.c_str(), type, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT)
                      : H5I_INVALID_HID,
                   H5Dclose);
  if (!set.valid()) fail(fmt::format("cannot write dataset {}", name));
  // This process' rows: a union of hyperslabs of the file, one contiguous block in memory.
  const Handle file_space(H5Dget_space(set.get()), H5Sclose);
  hsize_t rows = 0;
  bool selected = file_space.valid() && H5Sselect_none(file_space.get()) >= 0;
  std::uint64_t sum = 0;
  const auto* bytes = static_cast<const unsigned char*>(local);
  for (const RowRun& r : runs) {
    if (r.count == 0) continue;
    if (r.first + r.count > shape[0]) fail(fmt::format("dataset {}: rows beyond its {}", name, shape[0]));
    std::vector<hsize_t> start(shape.size(), 0), count = shape;
    start[0] = r.first;
    count[0] = r.count;
    selected = selected &&
               H5Sselect_hyperslab(file_space.get(), H5S_SELECT_OR, start.data(), nullptr, count.data(), nullptr) >= 0;
    sum += indexed_checksum(bytes + 8 * rows * per_row, static_cast<std::size_t>(r.count * per_row), r.first * per_row);
    rows += r.count;
  }
  const hsize_t local_values = rows * per_row;
  const Handle memory_space(H5Screate_simple(1, &local_values, nullptr), H5Sclose);
  if (local_values == 0 && memory_space.valid()) H5Sselect_none(memory_space.get());
  const Handle transfer(H5Pcreate(H5P_DATASET_XFER), H5Pclose);
  if (comm_ != MPI_COMM_NULL && transfer.valid()) H5Pset_dxpl_mpio(transfer.get(), H5FD_MPIO_COLLECTIVE);
  if (n > 0 && (!selected || !memory_space.valid() ||
                H5Dwrite(set.get(), type, memory_space.get(), file_space.get(), transfer.get(), local) < 0))
    fail(fmt::format("cannot write dataset {}", name));
  if (comm_ != MPI_COMM_NULL) {  // unsigned addition wraps: the sum mod 2^64 of every process' terms
    std::uint64_t total = 0;
    MPI_Allreduce(&sum, &total, 1, MPI_UINT64_T, MPI_SUM, comm_);
    sum = total;
  }
  attribute(set.get(), kChecksumAttribute, H5T_NATIVE_UINT64, {}, &sum);
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
// dataspace is unreadable or claims more values than `limit` (a corrupt file must not make
// us allocate what it cannot hold).
template <class T>
bool sized_from(hid_t space_id, Array<T>& a, hsize_t limit) {
  const Handle space(space_id, H5Sclose);
  if (!space.valid()) return false;
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) return false;
  a.shape.resize(static_cast<std::size_t>(rank));
  if (H5Sget_simple_extent_dims(space.get(), a.shape.data(), nullptr) < 0) return false;
  hsize_t n = 1;
  for (const hsize_t d : a.shape) {
    if (d != 0 && n > limit / d) return false;
    n *= d;
  }
  if (n > limit) return false;
  a.values.resize(static_cast<std::size_t>(n));
  return true;
}

// The size of the file holding `loc`, in bytes (0 if unknown).
hsize_t file_bytes(hid_t loc) {
  const Handle file(H5Iget_file_id(loc), H5Fclose);
  hsize_t size = 0;
  if (!file.valid() || H5Fget_filesize(file.get(), &size) < 0) return 0;
  return size;
}

// The most values of `type_id` (owned) the file can hold: each takes its bytes on disk.
hsize_t value_limit(hid_t loc, hid_t type_id) {
  const Handle type(type_id, H5Tclose);
  const std::size_t bytes = type.valid() ? H5Tget_size(type.get()) : 0;
  return file_bytes(loc) / std::max<std::size_t>(bytes, 1);
}

// The dataset `name` of loc, opened; `path` names it in messages.
Handle open_dataset(const H5Io& io, hid_t loc, const std::string& name, const std::string& path) {
  if (H5Lexists(loc, name.c_str(), H5P_DEFAULT) <= 0) io.fail(fmt::format("missing dataset {}", path));
  Handle set(H5Dopen2(loc, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.valid())
    io.fail(fmt::format("{} is not a readable dataset{}", path,
                        error_stack_mentions_checksum() ? " (checksum mismatch: the file is corrupt)" : ""));
  return set;
}

bool has_fletcher32(hid_t set) {
  const Handle dcpl(H5Dget_create_plist(set), H5Pclose);
  unsigned flags = 0;
  std::size_t nelmts = 0;
  unsigned config = 0;
  return dcpl.valid() &&
         H5Pget_filter_by_id2(dcpl.get(), H5Z_FILTER_FLETCHER32, &flags, &nelmts, nullptr, 0, nullptr, &config) >= 0;
}

bool is_compact(hid_t set) {
  const Handle dcpl(H5Dget_create_plist(set), H5Pclose);
  return dcpl.valid() && H5Pget_layout(dcpl.get()) == H5D_COMPACT;
}

}  // namespace

template <class T>
Array<T> H5Io::read(hid_t loc, const std::string& name, hid_t type, const std::string& path) const {
  const Handle set = open_dataset(*this, loc, name, path);
  Array<T> a;
  if (!sized_from(H5Dget_space(set.get()), a, value_limit(loc, H5Dget_type(set.get()))))
    fail(fmt::format("{}: unreadable shape, or more values than the file holds (corrupt?)", path));
  const bool require_checksums = version_ >= 2;  // version 1 predates them
  if (require_checksums && !(a.shape.empty() ? is_compact(set.get()) : a.values.empty() || has_fletcher32(set.get())))
    fail(fmt::format("{} carries no checksum (every dataset of this format version must)", path));
  if (!a.values.empty() && H5Dread(set.get(), type, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.values.data()) < 0)
    fail(error_stack_mentions_checksum()
             ? fmt::format("dataset {} fails its checksum: the file is corrupt", path)
             : fmt::format("cannot read dataset {} (corrupt file?)", path));
  if (require_checksums) {
    if (H5Aexists(set.get(), kChecksumAttribute) <= 0)
      fail(fmt::format("{} carries no checksum (every dataset of this format version must)", path));
    const auto sum = read_attribute<std::uint64_t>(set.get(), kChecksumAttribute, H5T_NATIVE_UINT64, path + "@checksum");
    static_assert(sizeof(T) == 8, "checkpoint datasets hold 8-byte values");
    const std::uint64_t expected = version_ == 2 ? fnv_checksum(a.values.data(), a.values.size(), sizeof(T))
                                                 : indexed_checksum(a.values.data(), a.values.size(), 0);
    if (sum.values.size() != 1 || sum.values[0] != expected)
      fail(fmt::format("dataset {} fails its checksum: the file is corrupt", path));
  }
  return a;
}

std::vector<hsize_t> H5Io::shape_of(hid_t loc, const std::string& name, const std::string& path) const {
  const Handle set = open_dataset(*this, loc, name, path);
  Array<std::uint64_t> a;
  if (!sized_from(H5Dget_space(set.get()), a, value_limit(loc, H5Dget_type(set.get()))))
    fail(fmt::format("{}: unreadable shape, or more values than the file holds (corrupt?)", path));
  return a.shape;
}

template <class T>
Rows<T> H5Io::read_rows(hid_t loc, const std::string& name, hid_t type, const std::string& path, RowRun rows) const {
  static_assert(sizeof(T) == 8, "checkpoint datasets hold 8-byte values");
  const Handle set = open_dataset(*this, loc, name, path);
  Rows<T> out;
  const Handle file_space(H5Dget_space(set.get()), H5Sclose);
  const int dims = file_space.valid() ? H5Sget_simple_extent_ndims(file_space.get()) : -1;
  if (dims < 1) fail(fmt::format("{}: expected an array of rows", path));
  out.shape.resize(static_cast<std::size_t>(dims));
  if (H5Sget_simple_extent_dims(file_space.get(), out.shape.data(), nullptr) < 0)
    fail(fmt::format("{}: unreadable shape", path));
  if (rows.first + rows.count > out.shape[0])
    fail(fmt::format("{}: rows [{}, {}) asked of {}", path, rows.first, rows.first + rows.count, out.shape[0]));
  hsize_t per_row = 1;
  for (std::size_t i = 1; i < out.shape.size(); ++i) per_row *= out.shape[i];
  if (per_row > 0 && rows.count > value_limit(loc, H5Dget_type(set.get())) / per_row)
    fail(fmt::format("{}: more values than the file holds (corrupt?)", path));
  if (out.shape[0] > 0 && per_row > 0 && !has_fletcher32(set.get()))
    fail(fmt::format("{} carries no checksum (every dataset of this format version must)", path));
  if (H5Aexists(set.get(), kChecksumAttribute) <= 0)
    fail(fmt::format("{} carries no checksum (every dataset of this format version must)", path));
  const auto sum = read_attribute<std::uint64_t>(set.get(), kChecksumAttribute, H5T_NATIVE_UINT64, path + "@checksum");
  if (sum.values.size() != 1) fail(fmt::format("{}@checksum is not one value", path));
  out.stored_checksum = sum.values[0];
  const hsize_t n = rows.count * per_row;
  out.values.resize(static_cast<std::size_t>(n));
  if (n > 0) {
    std::vector<hsize_t> start(out.shape.size(), 0), count = out.shape;
    start[0] = rows.first;
    count[0] = rows.count;
    const Handle memory_space(H5Screate_simple(1, &n, nullptr), H5Sclose);
    if (H5Sselect_hyperslab(file_space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0 ||
        !memory_space.valid() ||
        H5Dread(set.get(), type, memory_space.get(), file_space.get(), H5P_DEFAULT, out.values.data()) < 0)
      fail(error_stack_mentions_checksum() ? fmt::format("dataset {} fails its checksum: the file is corrupt", path)
                                           : fmt::format("cannot read dataset {} (corrupt file?)", path));
  }
  out.checksum_part = indexed_checksum(out.values.data(), out.values.size(), rows.first * per_row);
  return out;
}

template <class T>
Array<T> H5Io::read_attribute(hid_t loc, const std::string& name, hid_t type, const std::string& path) const {
  if (H5Aexists(loc, name.c_str()) <= 0) fail(fmt::format("missing attribute {}", path));
  const Handle attr(H5Aopen(loc, name.c_str(), H5P_DEFAULT), H5Aclose);
  Array<T> a;
  if (!attr.valid() || !sized_from(H5Aget_space(attr.get()), a, value_limit(loc, H5Aget_type(attr.get()))))
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
  if (H5Tget_size(type.get()) > 4096) fail(fmt::format("{} is implausibly long (corrupt?)", path));
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

#if defined(__SANITIZE_ADDRESS__)
// HDF5 1.10 leaks blocks when it fails to decode a corrupt file (and is asked not to shut
// down at exit, QuietErrors): under LeakSanitizer those leaks are HDF5's, not ours.
extern "C" const char* __lsan_default_suppressions() { return "leak:libhdf5\n"; }
#endif

Handle checksummed_file_access() {
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (fapl.valid()) H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V110, H5F_LIBVER_LATEST);
  return fapl;
}

Handle mpio_file_access(MPI_Comm comm) {
  Handle fapl = checksummed_file_access();
  if (fapl.valid() && H5Pset_fapl_mpio(fapl.get(), comm, MPI_INFO_NULL) < 0) return {};
  return fapl;
}

bool error_stack_mentions_checksum() {
  bool found = false;
  const auto visit = [](unsigned, const H5E_error2_t* e, void* data) -> herr_t {
    if (e->desc && (std::strstr(e->desc, "checksum") || std::strstr(e->desc, "Fletcher32")))
      *static_cast<bool*>(data) = true;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, visit, &found);
  return found;
}

template Array<double> H5Io::read<double>(hid_t, const std::string&, hid_t, const std::string&) const;
template Array<std::int64_t> H5Io::read<std::int64_t>(hid_t, const std::string&, hid_t, const std::string&) const;
template Array<std::uint64_t> H5Io::read<std::uint64_t>(hid_t, const std::string&, hid_t, const std::string&) const;
template Rows<double> H5Io::read_rows<double>(hid_t, const std::string&, hid_t, const std::string&, RowRun) const;
template Rows<std::uint64_t> H5Io::read_rows<std::uint64_t>(hid_t, const std::string&, hid_t, const std::string&,
                                                            RowRun) const;
template Array<double> H5Io::read_attribute<double>(hid_t, const std::string&, hid_t, const std::string&) const;
template Array<std::uint64_t> H5Io::read_attribute<std::uint64_t>(hid_t, const std::string&, hid_t,
                                                                  const std::string&) const;
template Array<std::int32_t> H5Io::read_attribute<std::int32_t>(hid_t, const std::string&, hid_t,
                                                                const std::string&) const;

}  // namespace capsflow::io::detail
