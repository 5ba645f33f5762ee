#pragma once
// What every reader of a checkpoint checks first (internal to the readers): the file opens,
// is a capsflow checkpoint of a version this build reads, of this dimension and domain, with
// a leaf count per level no deeper than the run's; then its scalars and extras against the
// run, and its field names. Each failure goes through H5Io::fail (CheckpointError naming the
// file).
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "io/checkpoint.hpp"
#include "io/h5_file.hpp"

namespace capsflow::io::detail {

struct CheckpointHeader {
  Handle file;
  int version = 0;
  std::vector<std::int64_t> leaf_count;  // leaves per level, levels 0 to the file's depth
};

// Opens the file (each process alone, read-only) and checks its header against the tree's
// options; io learns the format version.
template <int D>
CheckpointHeader read_header(H5Io& io, const std::filesystem::path& path, const tree::Tree<D>& tree);

// /scalars and /extras (but those named in `leaf_arrays`, which hold rows per leaf), checked
// against the run.
RestoredState read_scalars_and_extras(const H5Io& io, hid_t root, const CheckpointExpectations& expect,
                                      std::span<const std::string> leaf_arrays);

// The file's /fields are the saved fields the run registers.
template <int D>
void check_field_names(const H5Io& io, hid_t fields, const tree::Tree<D>& tree);

// Whether `key` names a cell of the level-l grid on these roots.
template <int D>
bool key_in_grid(const tree::TreeOptions<D>& o, int level, tree::Key key) {
  const tree::Coords<D> ijk = tree::morton_decode<D>(key);
  for (int d = 0; d < D; ++d)
    if (ijk[d] < 0 || ijk[d] >= (o.roots[d] << level)) return false;
  return tree::morton_encode<D>(ijk) == key;
}

}  // namespace capsflow::io::detail
