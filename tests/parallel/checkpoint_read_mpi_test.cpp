// The checkpoint reader of N ranks (io::read_checkpoint_distributed) on 1-4 ranks, against
// the one-rank reader followed by tree::distribute: the same partition, the same local tree
// and, on every owned cell (leaves and parents), the same values to the bit; per-leaf extras
// on their leaves. Damaged files (a flipped value, a leaf twice, a leaf missing, a leaf set
// that is not 2:1 balanced) stop every rank with the same one-line CheckpointError.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <unistd.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "forest_fixtures.hpp"
#include "io/checkpoint.hpp"
#include "io/h5_file.hpp"
#include "parallel/reduce.hpp"
#include "tree/leaf_order.hpp"

namespace capsflow::io {
namespace {

using ::testing::HasSubstr;

tree::TreeOptions<3> channel() {
  return {.roots = {2, 1, 1}, .root_size = 1.0, .origin = {0.0, 0.0, 0.0}, .periodic = {true, false, false},
          .max_level = 5};
}

const std::vector<std::string> kFields{"u", "pressure"};

// The bare tree of the run: roots and fields (one of them restricted and prolonged).
tree::Tree<3> bare() {
  tree::Tree<3> t(channel());
  (void)t.add_field({.name = "u", .prolongation = tree::Prolongation::limited});
  (void)t.add_field({.name = "pressure"});
  return t;
}

double value_of(int field, int level, tree::Key key) {
  return (field == 0 ? 1.0 : -7.0) * std::sin(1e-3 * static_cast<double>(key) + level) / 3.0;
}

// This launch's scratch folder (rank 0's process id: launches on other rank counts may run
// at the same time), removed by rank 0 when the tests end.
const std::filesystem::path& scratch_dir() {
  struct Dir {
    std::filesystem::path path;
    bool owner = false;
    ~Dir() {
      std::error_code ec;
      if (owner) std::filesystem::remove_all(path, ec);
    }
  };
  static const Dir dir = [] {
    const parallel::Comm comm = parallel::Comm::world();
    long id = static_cast<long>(::getpid());
    if (comm.distributed()) MPI_Bcast(&id, 1, MPI_LONG, 0, comm.handle());
    return Dir{std::filesystem::temp_directory_path() / ("capsflow_checkpoint_mpi_test." + std::to_string(id)),
               comm.is_root()};
  }();
  return dir.path;
}

// The same file on every rank: rank 0 writes it (one rank's writer), every rank waits.
std::filesystem::path shared_file(const std::string& name) {
  const parallel::Comm comm = parallel::Comm::world();
  const std::filesystem::path& dir = scratch_dir();
  if (comm.is_root()) {
    std::filesystem::create_directories(dir);
    tree::Tree<3> t = tree::testing::uneven_tree(channel());
    (void)t.add_field({.name = "u", .prolongation = tree::Prolongation::limited});
    (void)t.add_field({.name = "pressure"});
    std::vector<double> faces;
    for (const tree::Index c : tree::owned_leaves_by_key(t)) {
      const int l = t.level_of(c);
      const tree::Key k = t.level(l).keys[static_cast<std::size_t>(c - t.level(l).base)];
      t.values(0)[c] = value_of(0, l, k);
      t.values(1)[c] = value_of(1, l, k);
      faces.insert(faces.end(), {double(l), double(k), -double(k)});
    }
    const std::vector<ExtraArray> extras{{.name = "capsule_0_positions", .shape = {2, 3}, .values = {1, 2, 3, 4, 5, 6}}};
    const std::vector<LeafArray> leaf_arrays{{.name = "faces", .per_leaf = 3, .values = faces}};
    write_checkpoint(dir / name, t, {.time = 0.5, .step = 50, .dt = 0.01}, extras, leaf_arrays);
  }
  comm.barrier();
  return dir / name;
}

TEST(CheckpointReadMpi, SameTreeAndValuesAsTheWholeReadThenDistributed) {
  const parallel::Comm comm = parallel::Comm::world();
  if (!comm.distributed()) GTEST_SKIP() << "one rank reads with read_checkpoint";
  const std::filesystem::path file = shared_file("whole.h5");
  const std::vector<std::string> per_leaf{"faces", "absent"};

  tree::Tree<3> mine = bare();
  DistributedRestart<3> r = read_checkpoint_distributed(comm, file, mine, {}, per_leaf);
  tree::Tree<3> whole = bare();
  const RestoredState s = read_checkpoint(file, whole);
  const auto forest = tree::distribute(comm, whole);

  EXPECT_EQ(r.state.scalars, s.scalars);
  ASSERT_EQ(r.state.extras.size(), 1u) << "the per-leaf extras are not among the state's";
  EXPECT_EQ(r.state.extras[0].name, "capsule_0_positions");
  EXPECT_TRUE(r.forest->partition() == forest->partition());
  EXPECT_EQ(mine.num_cells(), whole.num_cells());
  EXPECT_EQ(mine.owned_leaves().size(), whole.owned_leaves().size());
  // Every owned active cell (leaves and restricted parents), both fields, bit for bit.
  int compared = 0;
  for (int l = 0; l <= std::min(mine.depth(), whole.depth()); ++l) {
    const tree::Level<3>& lv = mine.level(l);
    for (tree::Index i = 0; i < lv.n_active; ++i) {
      const tree::Index c = lv.base + i;
      if (!mine.owns(c)) continue;
      const tree::Index w = whole.find(l, tree::morton_decode<3>(lv.keys[static_cast<std::size_t>(i)]));
      ASSERT_NE(w, tree::kNone);
      for (int f = 0; f < 2; ++f)
        EXPECT_EQ(std::bit_cast<std::uint64_t>(mine.values(f)[c]), std::bit_cast<std::uint64_t>(whole.values(f)[w]));
      ++compared;
    }
  }
  EXPECT_GT(parallel::global_sum(comm, std::int64_t{compared}), 0);
  // The per-leaf extra on this rank's leaves by (level, key); the absent one is left out.
  ASSERT_EQ(r.leaf_arrays.size(), 1u);
  EXPECT_EQ(r.leaf_arrays[0].name, "faces");
  EXPECT_EQ(r.leaf_arrays[0].per_leaf, 3u);
  const std::vector<tree::Index> by_key = tree::owned_leaves_by_key(mine);
  ASSERT_EQ(r.leaf_arrays[0].values.size(), 3 * by_key.size());
  for (std::size_t i = 0; i < by_key.size(); ++i) {
    const int l = mine.level_of(by_key[i]);
    const tree::Key k = mine.level(l).keys[static_cast<std::size_t>(by_key[i] - mine.level(l).base)];
    EXPECT_EQ(r.leaf_arrays[0].values[3 * i], double(l));
    EXPECT_EQ(r.leaf_arrays[0].values[3 * i + 1], double(k));
  }
  // The leaves of all ranks are the file's.
  EXPECT_EQ(parallel::global_sum(comm, static_cast<std::int64_t>(mine.owned_leaves().size())),
            static_cast<std::int64_t>(tree::testing::curve_leaves(tree::testing::uneven_tree(channel())).size()));
}

// Replaces the leaf set of a checkpoint (its keys, counts and fields, checksummed as the
// writer does) by `levels`: per level, its keys. Rank 0 edits, every rank waits.
void replace_leaves(const std::filesystem::path& file, const std::vector<std::vector<tree::Key>>& levels) {
  const parallel::Comm comm = parallel::Comm::world();
  if (comm.is_root()) {
    const detail::QuietErrors quiet;
    const detail::H5Io io(file.string(), detail::H5Io::Mode::write);
    const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    std::vector<std::int64_t> count;
    std::vector<tree::Key> keys;
    for (const auto& l : levels) {
      count.push_back(static_cast<std::int64_t>(l.size()));
      keys.insert(keys.end(), l.begin(), l.end());
    }
    for (const char* name : {"/tree/keys", "/tree/leaf_count", "/fields/u", "/fields/pressure", "/extras/faces"})
      ASSERT_GE(H5Ldelete(f, name, H5P_DEFAULT), 0);
    const hid_t t = H5Gopen2(f, "tree", H5P_DEFAULT), fields = H5Gopen2(f, "fields", H5P_DEFAULT);
    io.write(t, "leaf_count", H5T_NATIVE_INT64, {count.size()}, count.data());
    io.write(t, "keys", H5T_NATIVE_UINT64, {keys.size()}, keys.data());
    const std::vector<double> zeros(keys.size(), 0.0);
    for (const char* name : {"u", "pressure"}) io.write(fields, name, H5T_NATIVE_DOUBLE, {keys.size()}, zeros.data());
    H5Gclose(t);
    H5Gclose(fields);
    H5Fclose(f);
  }
  comm.barrier();
}

// The file's leaves, per level (keys ascending).
std::vector<std::vector<tree::Key>> file_levels() {
  const tree::Tree<3> t = tree::testing::uneven_tree(channel());
  std::vector<std::vector<tree::Key>> levels(static_cast<std::size_t>(t.depth()) + 1);
  for (const tree::Index c : tree::owned_leaves_by_key(t)) {
    const int l = t.level_of(c);
    levels[static_cast<std::size_t>(l)].push_back(t.level(l).keys[static_cast<std::size_t>(c - t.level(l).base)]);
  }
  return levels;
}

// Every rank's CheckpointError, the same on all of them.
std::string error_on_every_rank(const std::filesystem::path& file) {
  const parallel::Comm comm = parallel::Comm::world();
  tree::Tree<3> t = bare();
  std::string message;
  try {
    if (comm.distributed()) (void)read_checkpoint_distributed(comm, file, t, {}, std::vector<std::string>{"faces"});
    else (void)read_checkpoint(file, t);
  } catch (const CheckpointError& e) {
    message = e.what();
  }
  EXPECT_THAT(message, HasSubstr(file.string() + ": "));
  EXPECT_THAT(message, ::testing::Not(HasSubstr("\n")));
  // The same message everywhere: its length and a hash of it agree.
  const std::int64_t length = static_cast<std::int64_t>(message.size());
  EXPECT_EQ(parallel::global_max(comm, length), -parallel::global_max(comm, -length));
  const std::int64_t hash = static_cast<std::int64_t>(std::hash<std::string>{}(message) >> 2);
  EXPECT_EQ(parallel::global_max(comm, hash), -parallel::global_max(comm, -hash));
  return message;
}

TEST(CheckpointReadMpi, DamageStopsEveryRankWithOneMessage) {
  // A value flipped in the middle of a field: HDF5's chunk checksum is rewritten, ours is not.
  const std::filesystem::path flipped = shared_file("flipped.h5");
  if (parallel::Comm::world().is_root()) {
    const hid_t f = H5Fopen(flipped.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    const hid_t set = H5Dopen2(f, "/fields/pressure", H5P_DEFAULT);
    const hid_t space = H5Dget_space(set);
    const hsize_t middle = static_cast<hsize_t>(H5Sget_simple_extent_npoints(space)) / 2, one = 1;
    H5Sselect_hyperslab(space, H5S_SELECT_SET, &middle, nullptr, &one, nullptr);
    const hid_t memory = H5Screate_simple(1, &one, nullptr);
    const double bad = 12345.0;
    EXPECT_GE(H5Dwrite(set, H5T_NATIVE_DOUBLE, memory, space, H5P_DEFAULT, &bad), 0);
    H5Sclose(memory);
    H5Sclose(space);
    H5Dclose(set);
    H5Fclose(f);
  }
  parallel::Comm::world().barrier();
  EXPECT_THAT(error_on_every_rank(flipped), HasSubstr("dataset /fields/pressure fails its checksum"));

  // A leaf twice, a leaf missing: the leaves do not tile the roots.
  std::vector<std::vector<tree::Key>> levels = file_levels();
  const std::filesystem::path twice = shared_file("twice.h5");
  levels.back().insert(levels.back().begin() + 3, levels.back()[3]);
  replace_leaves(twice, levels);
  EXPECT_THAT(error_on_every_rank(twice), HasSubstr("do not form a balanced tree on these roots"));
  const std::filesystem::path missing = shared_file("missing.h5");
  levels = file_levels();
  levels[2].erase(levels[2].begin() + static_cast<std::ptrdiff_t>(levels[2].size() / 2));
  replace_leaves(missing, levels);
  EXPECT_THAT(error_on_every_rank(missing), HasSubstr("do not form a balanced tree on these roots"));

  // Tiling but not balanced: root 0 refined to level 3 in its corner next to the periodic
  // side, root 1 a single leaf: the level-3 leaves' parent borders root 1 across x.
  std::vector<std::vector<tree::Key>> unbalanced(4);
  unbalanced[0] = {tree::morton_encode<3>({1, 0, 0})};
  for (tree::Key k = 1; k < 8; ++k) unbalanced[1].push_back(k);
  for (tree::Key k = 1; k < 8; ++k) unbalanced[2].push_back(k);
  for (tree::Key k = 0; k < 8; ++k) unbalanced[3].push_back(k);
  const std::filesystem::path skewed = shared_file("unbalanced.h5");
  replace_leaves(skewed, unbalanced);
  EXPECT_THAT(error_on_every_rank(skewed), HasSubstr("do not form a balanced tree on these roots"));

}

}  // namespace
}  // namespace capsflow::io
