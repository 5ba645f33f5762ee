#pragma once
// Thin RAII over the HDF5 C API for the checkpoint reader and writer (internal; includes
// hdf5.h). Every failing call becomes an exception from `fail`, which names the file and
// the object; HDF5's own error stack printing is silenced while a File is open.
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace capsflow::io::detail {

inline constexpr char kCheckpointFormat[] = "capsflow checkpoint";
// Version 2 added checksums, version 3 made them sums that ranks writing their own rows add
// up (docs/checkpoint-format.md); versions 1 and 2 still read.
inline constexpr int kCheckpointVersion = 3;
inline constexpr int kOldestCheckpointVersion = 1;

class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = H5I_INVALID_HID; }
  Handle& operator=(Handle&& o) noexcept {
    std::swap(id_, o.id_);
    std::swap(close_, o.close_);
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id_ >= 0 && close_) close_(id_);
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  herr_t (*close_)(hid_t) = nullptr;
};

// Silences HDF5's automatic error printing for the lifetime of the object. Every HDF5 use
// of capsflow starts with one, so it also asks HDF5 (before the library initialises) not to
// shut down at exit: after reading a corrupt file HDF5 1.10 can keep internal blocks that
// make its exit-time shutdown print "infinite loop closing library" to stderr, a second
// line after our one-line error. Files are closed explicitly, so nothing is lost.
class QuietErrors {
 public:
  QuietErrors() {
    static const bool no_shutdown_at_exit = H5dont_atexit() >= 0;
    (void)no_shutdown_at_exit;
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

// A dataset read whole: its shape and its values converted to T by HDF5.
template <class T>
struct Array {
  std::vector<hsize_t> shape;
  std::vector<T> values;
};

// A dataset's checksum attribute (docs/checkpoint-format.md). Version 3: the sum, mod 2^64,
// over its values i (row-major; 8-byte values) of mix(i, the value's 64 bits): each process
// adds the terms of the rows it writes, and the sums add up. Version 2: FNV-1a 64 over the
// values' little-endian bytes.
std::uint64_t indexed_checksum(const void* data, std::size_t values, std::uint64_t first_index);
std::uint64_t fnv_checksum(const void* data, std::size_t values, std::size_t value_bytes);

// Rows [first, first + count) of a dataset's first dimension.
struct RowRun {
  hsize_t first = 0, count = 0;
};

// Some rows of a version-3 dataset, read by one of the processes that share it: the
// dataset's whole shape, the rows' values, their terms of the checksum (the processes' parts
// add up to the stored sum) and the stored sum.
template <class T>
struct Rows {
  std::vector<hsize_t> shape;
  std::vector<T> values;
  std::uint64_t checksum_part = 0;
  std::uint64_t stored_checksum = 0;
};

// Reading and writing helpers. Failures throw CheckpointError ("<file>: <what>") when
// reading, std::runtime_error when writing (a write failure is not the file's fault).
// Writing on N processes (comm != MPI_COMM_NULL, the file opened with mpio_file_access):
// every dataset and attribute is created by all of them alike, and each writes its rows.
class H5Io {
 public:
  enum class Mode { read, write };
  H5Io(std::string file, Mode mode, MPI_Comm comm = MPI_COMM_NULL)
      : file_(std::move(file)), mode_(mode), comm_(comm) {}

  [[noreturn]] void fail(const std::string& what) const;

  Handle group(hid_t loc, const std::string& name, bool create) const;
  // Datasets are written checksummed: arrays chunked with the Fletcher32 filter, scalars
  // compact (their value lives in the object header, which the file format checksums).
  // On N processes rank 0's data is written (scalars: every process passes the same).
  void write(hid_t loc, const std::string& name, hid_t type, const std::vector<hsize_t>& shape,
             const void* data) const;
  // An array whose rows this process holds: `runs` of rows of `shape`, their values one run
  // after the other in `local`. Collective on N processes. 8-byte types.
  void write_rows(hid_t loc, const std::string& name, hid_t type, const std::vector<hsize_t>& shape,
                  const std::vector<RowRun>& runs, const void* local) const;
  void attribute(hid_t loc, const std::string& name, hid_t type, const std::vector<hsize_t>& shape,
                 const void* data) const;
  void string_attribute(hid_t loc, const std::string& name, const std::string& value) const;

  // Reading: the file's format version says which checksums every dataset must carry.
  void expect_format_version(int version) { version_ = version; }

  // `path` names the object in messages ("/tree/keys"). A read that fails its checksum
  // says so.
  template <class T>
  Array<T> read(hid_t loc, const std::string& name, hid_t type, const std::string& path) const;
  template <class T>
  Array<T> read_attribute(hid_t loc, const std::string& name, hid_t type, const std::string& path) const;
  std::string read_string_attribute(hid_t loc, const std::string& name, const std::string& path) const;
  // A dataset's shape, without reading it.
  std::vector<hsize_t> shape_of(hid_t loc, const std::string& name, const std::string& path) const;
  // Rows [rows.first, rows.first + rows.count) of a checksummed (version 3) dataset, every
  // value of each; the caller compares the processes' summed checksum_part with
  // stored_checksum. Local: no other process takes part.
  template <class T>
  Rows<T> read_rows(hid_t loc, const std::string& name, hid_t type, const std::string& path, RowRun rows) const;
  // The names of a group's members, in name order.
  std::vector<std::string> members(hid_t group, const std::string& path) const;

 private:
  std::string file_;
  Mode mode_;
  MPI_Comm comm_ = MPI_COMM_NULL;
  int version_ = 1;  // reading: 1 carries no checksums
};

// A file access property list for writing on the processes of comm (MPI-IO), with the
// checksummed format features of checksummed_file_access.
Handle mpio_file_access(MPI_Comm comm);

// The property list that makes HDF5 checksum all of a file's metadata (superblock v2+,
// object headers v2, checksummed chunk indexes): format features of HDF5 1.10.
Handle checksummed_file_access();

// True when HDF5's current error stack reports a checksum failure (data or metadata).
bool error_stack_mentions_checksum();
}  // namespace capsflow::io::detail
