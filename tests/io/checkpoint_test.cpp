// HDF5 checkpoints: an exact round trip of an adaptive tree, its fields, extra arrays and
// scalars; clear errors for corrupt and mismatched files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>
#include <span>

#include "io/checkpoint.hpp"
#include "io/h5_file.hpp"
#include "scratch_dir.hpp"

namespace capsflow::io {
namespace {

using ::testing::HasSubstr;

tree::TreeOptions<3> channel(int max_level = 5) {
  return {.roots = {2, 1, 1}, .root_size = 1.0, .origin = {-1.0, 0.0, 0.0}, .periodic = {true, false, false},
          .max_level = max_level};
}

// An adaptive octree (finest around a sphere) with two fields of awkward values.
tree::Tree<3> saved_tree() {
  tree::Tree<3> t(channel());
  // Finest where the box meets the sphere of radius 0.3 around (0.1, 0.5, 0.5).
  (void)t.refine_to([](const tree::Box<3>& b) {
    double near = 0.0, far = 0.0;
    const double c[3] = {0.1, 0.5, 0.5};
    for (int d = 0; d < 3; ++d) {
      const double lo = b.lo[d] - c[d], hi = b.hi[d] - c[d];
      const double n = lo > 0 ? lo : (hi < 0 ? -hi : 0.0);
      const double f = std::max(std::abs(lo), std::abs(hi));
      near += n * n;
      far += f * f;
    }
    return std::sqrt(near) <= 0.3 && std::sqrt(far) >= 0.3 ? 5 : 1;
  });
  const tree::FieldId p = t.add_field({.name = "pressure"});
  const tree::FieldId u = t.add_field({.name = "u", .prolongation = tree::Prolongation::limited});
  for (const tree::Index c : t.leaves()) {
    const auto x = t.center(c);
    t.values(p)[c] = std::sin(12.345 * x[0]) * std::exp(x[1]) / 3.0;
    t.values(u)[c] = std::cbrt(x[2] + 0.1) * 1e-7 + c;
  }
  return t;
}

// A bare tree of the run, with the fields registered (in another order than when saved).
tree::Tree<3> run_tree(const tree::TreeOptions<3>& o, std::vector<std::string> names) {
  tree::Tree<3> t(o);
  for (auto& n : names) (void)t.add_field({.name = std::move(n)});
  return t;
}

const std::vector<ExtraArray> kExtras{
    {.name = "membrane_nodes", .shape = {4, 3}, .values = {0.1, 0.2, 0.3, 1, 2, 3, -1, -2, -3, 1e-300, 5e300, 0}},
    {.name = "reference_volume", .shape = {}, .values = {4.18879020478639}}};
const CheckpointScalars kScalars{.time = 1.0 / 3.0, .step = 123456789012, .dt = 1e-3 / 7};

std::string checkpoint_error(const std::filesystem::path& path, tree::Tree<3>& t,
                             const CheckpointExpectations& expect = {}) {
  try {
    (void)read_checkpoint(path, t, expect);
  } catch (const CheckpointError& e) {
    EXPECT_THAT(std::string(e.what()), ::testing::Not(HasSubstr("\n")));
    EXPECT_THAT(std::string(e.what()), HasSubstr(path.string() + ": "));
    return e.what();
  }
  ADD_FAILURE() << "no CheckpointError";
  return {};
}

class io_checkpoint : public ::testing::Test {
 protected:
  io_checkpoint() : dir_("checkpoint"), saved_(saved_tree()), file_(dir_.path() / "checkpoint_000100.h5") {
    write_checkpoint(file_, saved_, kScalars, kExtras);
  }
  ScratchDir dir_;
  tree::Tree<3> saved_;
  std::filesystem::path file_;
};

TEST_F(io_checkpoint, RoundTripIsExact) {
  ASSERT_GE(saved_.depth(), 5);
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  const RestoredState s = read_checkpoint(file_, t);
  EXPECT_EQ(s.scalars, kScalars);
  EXPECT_EQ(s.extras.size(), 2u);
  EXPECT_EQ(s.extras, kExtras);  // name order, shapes, values

  ASSERT_EQ(t.num_leaves(), saved_.num_leaves());
  for (std::size_t i = 0; i < t.leaves().size(); ++i) {
    const tree::Index a = saved_.leaves()[i], b = t.leaves()[i];
    ASSERT_EQ(t.level_of(b), saved_.level_of(a));
    ASSERT_EQ(t.coords(b), saved_.coords(a));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(t.values(1)[b]), std::bit_cast<std::uint64_t>(saved_.values(0)[a]));
    EXPECT_EQ(std::bit_cast<std::uint64_t>(t.values(0)[b]), std::bit_cast<std::uint64_t>(saved_.values(1)[a]));
  }
}

TEST_F(io_checkpoint, TwoDimensionalRoundTrip) {
  tree::Tree<2> t2({.roots = {3, 1}, .max_level = 6});
  (void)t2.refine_to([](const tree::Box<2>& b) { return b.lo[0] < 0.5 && b.lo[1] < 0.25 ? 6 : 2; });
  const tree::FieldId f = t2.add_field({.name = "f"});
  for (const tree::Index c : t2.leaves()) t2.values(f)[c] = 1.0 / (1.0 + c);
  write_checkpoint(dir_.path() / "c2.h5", t2, {.time = 2.0, .step = 7, .dt = 0.5});
  tree::Tree<2> back({.roots = {3, 1}, .max_level = 6});
  (void)back.add_field({.name = "f"});
  const RestoredState s = read_checkpoint(dir_.path() / "c2.h5", back);
  EXPECT_EQ(s.scalars.step, 7);
  EXPECT_TRUE(s.extras.empty());
  ASSERT_EQ(back.num_leaves(), t2.num_leaves());
  for (std::size_t i = 0; i < back.leaves().size(); ++i)
    EXPECT_EQ(back.values(0)[back.leaves()[i]], t2.values(f)[t2.leaves()[i]]);
}

TEST_F(io_checkpoint, TruncatedFile) {
  const auto size = std::filesystem::file_size(file_);
  std::filesystem::resize_file(file_, size / 2);
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t), HasSubstr("not a readable HDF5 file (truncated or corrupt?)"));
  EXPECT_EQ(t.depth(), 0) << "the tree is untouched";
}

TEST_F(io_checkpoint, NotAnHdf5FileOrMissing) {
  std::ofstream(dir_.path() / "junk.h5") << "not hdf5 at all\n";
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(dir_.path() / "junk.h5", t), HasSubstr("not a readable HDF5 file"));
  EXPECT_THAT(checkpoint_error(dir_.path() / "none.h5", t), HasSubstr("no such checkpoint file"));
}

TEST_F(io_checkpoint, MissingDataset) {
  {
    const hid_t f = H5Fopen(file_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    ASSERT_GE(H5Ldelete(f, "/scalars/dt", H5P_DEFAULT), 0);
    H5Fclose(f);
  }
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t), HasSubstr("missing dataset /scalars/dt"));
}

// Rewrites /tree/keys with `change` applied (the file keeps its structure). The file is
// marked format version 1 (no checksums), so the reader's own leaf-set checks are what
// catches the damage rather than the checksum.
template <class F>
void edit_keys(const std::filesystem::path& file, F change) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t version = H5Aopen(f, "format_version", H5P_DEFAULT);
  const std::int32_t one = 1;
  ASSERT_GE(H5Awrite(version, H5T_NATIVE_INT32, &one), 0);
  H5Aclose(version);
  const hid_t set = H5Dopen2(f, "/tree/keys", H5P_DEFAULT);
  const hid_t space = H5Dget_space(set);
  std::vector<std::uint64_t> keys(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space)));
  ASSERT_GE(H5Dread(set, H5T_NATIVE_UINT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, keys.data()), 0);
  change(keys);
  ASSERT_GE(H5Dwrite(set, H5T_NATIVE_UINT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, keys.data()), 0);
  H5Sclose(space);
  H5Dclose(set);
  H5Fclose(f);
}

TEST_F(io_checkpoint, CorruptLeafSet) {
  edit_keys(file_, [](std::vector<std::uint64_t>& k) { k.back() = ~std::uint64_t{0} >> 4; });
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t), HasSubstr("lies outside the level-5 grid"));

  edit_keys(file_, [](std::vector<std::uint64_t>& k) { k.back() = k[k.size() - 2]; });  // a leaf twice
  tree::Tree<3> t2 = run_tree(channel(), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t2), HasSubstr("do not form a balanced tree on these roots"));
  EXPECT_EQ(t2.depth(), 0) << "the tree is untouched";
}

TEST_F(io_checkpoint, MismatchedRun) {
  tree::TreeOptions<3> other = channel();
  other.roots = {4, 1, 1};
  tree::Tree<3> t = run_tree(other, {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t),
              HasSubstr("domain.roots is [2, 1, 1] in the checkpoint but [4, 1, 1] in this run"));

  other = channel();
  other.periodic = {false, false, false};
  tree::Tree<3> t2 = run_tree(other, {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t2), HasSubstr("domain.periodic is [1, 0, 0] in the checkpoint"));

  tree::Tree<3> t3 = run_tree(channel(), {"u", "v"});
  EXPECT_THAT(checkpoint_error(file_, t3),
              HasSubstr("the fields differ: the checkpoint has [pressure, u], this run registers [u, v]"));
  EXPECT_EQ(t3.depth(), 0) << "the tree is untouched";

  tree::Tree<3> t4 = run_tree(channel(3), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t4), HasSubstr("leaves at level 5, deeper than adapt.max_level = 3"));

  tree::Tree<2> t2d({.roots = {2, 1}, .max_level = 5});
  try {
    (void)read_checkpoint(file_, t2d);
    FAIL() << "no CheckpointError";
  } catch (const CheckpointError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("written by a 3D run, this run is 2D"));
  }
}

// Flips one bit of the first stored copy of `value` in the file (a value inside a
// dataset: the test picks one that occurs nowhere else).
void flip_bit_of(const std::filesystem::path& file, double value) {
  std::ifstream in(file, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const auto bits = std::bit_cast<std::array<char, 8>>(value);
  const std::size_t at = bytes.find(std::string_view(bits.data(), bits.size()));
  ASSERT_NE(at, std::string::npos) << "value not found in " << file;
  bytes[at + 3] = static_cast<char>(bytes[at + 3] ^ 0x10);
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

TEST_F(io_checkpoint, FlippedBitInAFieldFailsItsChecksum) {
  const tree::Index leaf = saved_.leaves()[saved_.leaves().size() / 2];
  flip_bit_of(file_, saved_.values(0)[leaf]);  // pressure
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t), HasSubstr("dataset /fields/pressure fails its checksum"));
  EXPECT_EQ(t.depth(), 0) << "the tree is untouched";
}

TEST_F(io_checkpoint, FlippedBitInAScalarFailsItsChecksum) {
  flip_bit_of(file_, kScalars.time);
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_THAT(checkpoint_error(file_, t), HasSubstr("checksum"));
  EXPECT_EQ(t.depth(), 0) << "the tree is untouched";
}

// Format version 1 (before checksums) still reads.
TEST_F(io_checkpoint, VersionOneStillReads) {
  {
    const hid_t f = H5Fopen(file_.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    const hid_t a = H5Aopen(f, "format_version", H5P_DEFAULT);
    const std::int32_t one = 1;
    ASSERT_GE(H5Awrite(a, H5T_NATIVE_INT32, &one), 0);
    H5Aclose(a);
    H5Fclose(f);
  }
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_EQ(read_checkpoint(file_, t).scalars, kScalars);
}

// A checkpoint whose values a run cannot continue from is refused before the tree changes.
class io_checkpoint_values : public io_checkpoint {
 protected:
  std::string error_for(const CheckpointScalars& s, const CheckpointExpectations& expect = {},
                        std::span<const ExtraArray> extras = kExtras) {
    write_checkpoint(file_, saved_, s, extras);
    tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
    std::string message = checkpoint_error(file_, t, expect);
    EXPECT_EQ(t.depth(), 0) << "the tree is untouched";
    return message;
  }
};

TEST_F(io_checkpoint_values, TimeMustBeFiniteAndWithinTheCase) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(error_for({.time = nan, .step = 1, .dt = 0.1}), HasSubstr("/scalars/time = nan: must be finite"));
  EXPECT_THAT(error_for({.time = -1e300, .step = 1, .dt = 0.1}), HasSubstr("/scalars/time = -1e+300: must be >= 0"));
  EXPECT_THAT(error_for({.time = 2.0, .step = 1, .dt = 0.1}, {.t_end = 2.0}),
              HasSubstr("/scalars/time = 2 is at or past time.t_end = 2 of this case: nothing left to run"));
  EXPECT_THAT(error_for({.time = 1.0, .step = -5, .dt = 0.1}), HasSubstr("/scalars/step = -5: must be >= 0"));
  EXPECT_THAT(error_for({.time = 1.0, .step = 5, .dt = 0.0}), HasSubstr("/scalars/dt = 0: must be finite and > 0"));
}

TEST_F(io_checkpoint_values, FieldAndExtraValuesMustBeFinite) {
  saved_.values(1)[saved_.leaves()[7]] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(error_for(kScalars), HasSubstr("/fields/u[7] = nan: every value must be finite"));
  saved_.values(1)[saved_.leaves()[7]] = 0.0;
  std::vector<ExtraArray> extras = kExtras;
  extras[0].values[4] = -std::numeric_limits<double>::infinity();
  EXPECT_THAT(error_for(kScalars, {}, extras), HasSubstr("/extras/membrane_nodes[4] = -inf"));
}

TEST_F(io_checkpoint_values, CapsulesMustMatchTheCase) {
  const std::vector<ExtraArray> one{{.name = "capsule_0_positions", .shape = {2, 3}, .values = {1, 2, 3, 4, 5, 6}}};
  using Nodes = std::vector<std::size_t>;
  EXPECT_THAT(error_for(kScalars, {.capsule_nodes = Nodes{}}, one),
              HasSubstr("the checkpoint holds 1 capsule(s), this case has 0"));
  EXPECT_THAT(error_for(kScalars, {.capsule_nodes = Nodes{2, 2}}, one),
              HasSubstr("the checkpoint holds 1 capsule(s), this case has 2"));
  EXPECT_THAT(error_for(kScalars, {.capsule_nodes = Nodes{642}}, one),
              HasSubstr("/extras/capsule_0_positions has shape [2, 3], capsule[0] of this case has 642 nodes"));
  tree::Tree<3> t = run_tree(channel(), {"u", "pressure"});
  EXPECT_EQ(read_checkpoint(file_, t, {.capsule_nodes = Nodes{2}}).extras, one);
}

TEST_F(io_checkpoint, BadNamesAreRejectedBeforeWriting) {
  const std::vector<ExtraArray> bad{{.name = "a/b", .shape = {1}, .values = {1.0}}};
  EXPECT_THROW(write_checkpoint(dir_.path() / "bad.h5", saved_, kScalars, bad), std::invalid_argument);
  const std::vector<ExtraArray> wrong_shape{{.name = "x", .shape = {2, 2}, .values = {1.0}}};
  EXPECT_THROW(write_checkpoint(dir_.path() / "bad.h5", saved_, kScalars, wrong_shape), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "bad.h5"));
}

// Format version 3's checksum: the ranks' sums over their own rows add up to the whole
// array's (whatever the split), and a zeroed, swapped or flipped value changes it.
TEST(CheckpointChecksum, RanksSumsAddUpAndEveryDamageShows) {
  std::vector<double> v(1000);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = std::sin(0.1 * static_cast<double>(i)) * 1e3;
  const std::uint64_t whole = detail::indexed_checksum(v.data(), v.size(), 0);
  for (const std::size_t split : {std::size_t{0}, std::size_t{1}, std::size_t{377}, std::size_t{999}})
    EXPECT_EQ(detail::indexed_checksum(v.data(), split, 0) + detail::indexed_checksum(v.data() + split, v.size() - split, split),
              whole);
  std::vector<double> zeroed = v;
  std::fill(zeroed.begin() + 100, zeroed.begin() + 164, 0.0);
  EXPECT_NE(detail::indexed_checksum(zeroed.data(), zeroed.size(), 0), whole);
  std::vector<double> swapped = v;
  std::swap(swapped[3], swapped[700]);
  EXPECT_NE(detail::indexed_checksum(swapped.data(), swapped.size(), 0), whole);
  std::vector<double> flipped = v;
  flipped[500] = std::bit_cast<double>(std::bit_cast<std::uint64_t>(flipped[500]) ^ 1u);
  EXPECT_NE(detail::indexed_checksum(flipped.data(), flipped.size(), 0), whole);
  // All zeros still sum to something that is not zero.
  const std::vector<double> zeros(64, 0.0);
  EXPECT_NE(detail::indexed_checksum(zeros.data(), zeros.size(), 0), 0u);
}

}  // namespace
}  // namespace capsflow::io
