// A checkpoint a run cannot continue from (issue 15): `capsflow run --restart` refuses it
// with one line and exit status 2 before touching the output directory — NaN or absurd
// times, NaN fields, another case's capsules, flipped bytes.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <limits>

#include "app_support.hpp"
#include "small_cavity.hpp"
#include "io/checkpoint.hpp"

namespace capsflow::app {
namespace {

using namespace testing;
using ::testing::HasSubstr;

const std::string kCavity = test_cases::small_cavity("[output]\ncheckpoint = true\n");

// A finished run (out/) with its final checkpoint, and the case to continue it.
class AppRestartErrors : public ::testing::Test {
 protected:
  AppRestartErrors() : dir_(scratch("restart_errors")) {
    case_ = write(dir_, "case.toml", kCavity);
    const auto r = capsflow("run " + case_.string() + " --quiet --out " + out().string(), dir_);
    EXPECT_EQ(r.status, 0) << r.err;
  }
  fs::path out() const { return dir_ / "out"; }
  fs::path checkpoint() const { return out() / "checkpoint_000002.h5"; }

  // Restarts into the run's own folder with a later t_end: refused, one line naming the
  // checkpoint and `message`, the folder as it was.
  void expect_refused(const std::string& message) {
    const std::string before = slurp(out() / "diagnostics.csv");
    const auto r = capsflow("run " + case_.string() + " --quiet --set time.t_end=0.04 --out " + out().string() +
                                " --restart " + checkpoint().string(),
                            dir_);
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_THAT(r.err, HasSubstr(checkpoint().string() + ": "));
    EXPECT_THAT(r.err, HasSubstr(message));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    EXPECT_EQ(slurp(out() / "diagnostics.csv"), before) << "the diagnostics are untouched";
  }

  // Reads the run's checkpoint, lets `change` edit it, and writes it back with capsflow's
  // own writer: a well-formed, checksummed file whose values are wrong.
  template <class F>
  void rewrite(F change) {
    tree::Tree<2> t({.roots = {1, 1}, .max_level = 4});
    for (const char* name : {"u.x", "u.y", "p", "pf", "g.x", "g.y"}) (void)t.add_field({.name = name});
    io::RestoredState state = io::read_checkpoint(checkpoint(), t);
    change(state.scalars, t, state.extras);
    io::write_checkpoint(checkpoint(), t, state.scalars, state.extras);
  }

  fs::path dir_, case_;
};

TEST_F(AppRestartErrors, NaNTime) {
  rewrite([](io::CheckpointScalars& s, auto&, auto&) { s.time = std::numeric_limits<double>::quiet_NaN(); });
  expect_refused("/scalars/time = nan: must be finite");
}

TEST_F(AppRestartErrors, HugeNegativeTime) {
  rewrite([](io::CheckpointScalars& s, auto&, auto&) { s.time = -1e300; });
  expect_refused("/scalars/time = -1e+300: must be >= 0");
}

TEST_F(AppRestartErrors, TimeAtTheEnd) {
  rewrite([](io::CheckpointScalars& s, auto&, auto&) { s.time = 0.04; });
  expect_refused("is at or past time.t_end = 0.04 of this case: nothing left to run");
}

TEST_F(AppRestartErrors, NaNVelocity) {
  rewrite([](auto&, tree::Tree<2>& t, auto&) { t.values(0)[t.leaves()[3]] = std::numeric_limits<double>::quiet_NaN(); });
  expect_refused("/fields/u.x[3] = nan: every value must be finite");
}

// The checkpoint of a capsule case restarted in a case without capsules.
TEST_F(AppRestartErrors, CapsuleOfAnotherCase) {
  rewrite([](auto&, auto&, std::vector<io::ExtraArray>& extras) {
    extras.push_back({.name = "capsule_0_positions", .shape = {642, 3}, .values = std::vector<double>(642 * 3, 0.0)});
  });
  expect_refused("the checkpoint holds 1 capsule(s), this case has 0");
}

TEST_F(AppRestartErrors, FlippedByteInsideADataset) {
  // Plant a value that occurs nowhere else in u.x, then flip a bit of its third byte.
  rewrite([](auto&, tree::Tree<2>& t, auto&) { t.values(0)[t.leaves()[5]] = 0.123456789012345; });
  std::string bytes = slurp(checkpoint());
  const auto pattern = std::bit_cast<std::array<char, 8>>(0.123456789012345);
  const std::size_t at = bytes.find(std::string_view(pattern.data(), 8));
  ASSERT_NE(at, std::string::npos);
  bytes[at + 2] = static_cast<char>(bytes[at + 2] ^ 0x01);
  std::ofstream(checkpoint(), std::ios::binary | std::ios::trunc) << bytes;
  expect_refused("dataset /fields/u.x fails its checksum: the file is corrupt");
}

}  // namespace
}  // namespace capsflow::app

namespace capsflow::app {
namespace {

// A checkpoint of format version 2 (FNV-1a checksums, before the collective writer of
// version 3; tests/app/data/README.md) still restarts, and its checksums still guard it.
class AppRestartFormatTwo : public ::testing::Test {
 protected:
  AppRestartFormatTwo() : dir_(scratch("restart_format_two")) {
    case_ = write(dir_, "case.toml", test_cases::small_cavity());
    fs::copy_file(fs::path(CAPSFLOW_APP_TEST_DATA) / "checkpoint_v2_small_cavity.h5", checkpoint());
  }
  fs::path checkpoint() const { return dir_ / "checkpoint_v2.h5"; }
  Result restart() const {
    return capsflow("run " + case_.string() + " --quiet --set fluid.carry_faces=true --set output.vtu=false --out " +
                        (dir_ / "out").string() + " --restart " + checkpoint().string(),
                    dir_);
  }
  fs::path dir_, case_;
};

TEST_F(AppRestartFormatTwo, Restarts) {
  const Result r = restart();
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string rows = slurp(dir_ / "out" / "diagnostics.csv");
  EXPECT_THAT(rows, HasSubstr("\n2,0.02,0.01,214,4,")) << "step 2 from the checkpoint's step 1: " << rows;
}

TEST_F(AppRestartFormatTwo, ItsChecksumsStillGuardIt) {
  tree::Tree<2> t({.roots = {1, 1}, .max_level = 4});
  for (const char* name : {"u.x", "u.y", "p", "pf", "g.x", "g.y"}) (void)t.add_field({.name = name});
  (void)io::read_checkpoint(checkpoint(), t);
  // A value of u.x that occurs once in the file, one bit of its third byte flipped.
  std::string bytes = slurp(checkpoint());
  std::size_t at = std::string::npos;
  for (const tree::Index c : t.leaves()) {
    const auto pattern = std::bit_cast<std::array<char, 8>>(t.values(0)[c]);
    const std::string_view p(pattern.data(), 8);
    at = bytes.find(p);
    if (at != std::string::npos && bytes.find(p, at + 1) == std::string::npos && t.values(0)[c] != 0.0) break;
    at = std::string::npos;
  }
  ASSERT_NE(at, std::string::npos);
  bytes[at + 2] = static_cast<char>(bytes[at + 2] ^ 0x01);
  std::ofstream(checkpoint(), std::ios::binary | std::ios::trunc) << bytes;
  const Result r = restart();
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr("dataset /fields/u.x fails its checksum: the file is corrupt"));
}

}  // namespace
}  // namespace capsflow::app
