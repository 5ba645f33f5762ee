// Bad input to capsflow run: one line on stderr naming the file or key, exit status 2, and
// nothing in --out touched.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app_support.hpp"
#include "post_channel.hpp"
#include "small_cavity.hpp"

namespace capsflow::app {
namespace {

using namespace testing;
using ::testing::HasSubstr;

const std::string kCavity = test_cases::small_cavity();

// Runs a bad case into an output directory holding a marker; checks status, message and
// that the directory is unchanged.
void expect_refused(const std::string& text, const std::string& extra, const std::string& message) {
  const fs::path dir = scratch("bad");
  const fs::path file = write(dir, "case.toml", text);
  fs::create_directories(dir / "out");
  write(dir / "out", "marker.txt", "keep");
  const auto r = capsflow("run " + file.string() + " --out " + (dir / "out").string() + " " + extra, dir);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr(message));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
  int files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir / "out")) ++files;
  EXPECT_EQ(files, 1) << "a refused run writes nothing";
  EXPECT_EQ(slurp(dir / "out" / "marker.txt"), "keep");
}

TEST(AppErrors, GoodCaseRuns) {
  const fs::path dir = scratch("good");
  const fs::path file = write(dir, "case.toml", kCavity);
  const auto r = capsflow("run " + file.string() + " --quiet --out " + (dir / "out").string(), dir);
  EXPECT_EQ(r.status, 0) << r.err;
}

TEST(AppErrors, MissingFile) {
  const fs::path dir = scratch("missing");
  const auto r = capsflow("run " + (dir / "nope.toml").string(), dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("nope.toml"));
}

TEST(AppErrors, SyntaxUnknownKeyWrongTypeAndRanges) {
  expect_refused(std::string(kCavity) + "oops = = 3\n", "", "line 16");
  expect_refused(std::string(kCavity) + "[extra]\nvalue = 1\n", "", "extra");
  expect_refused(kCavity, "--set fluid.Re=\"fast\"", "fluid.Re");
  expect_refused(kCavity, "--set time.dt=-0.001", "time.dt = -0.001 (from --set): must be > 0");
  expect_refused(kCavity, "--set adapt.min_level=5", "adapt.max_level");
  expect_refused(kCavity, "--set fluid.nonsense=1", "fluid.nonsense");
}

// The inner fluid is given per capsule: the old global keys name the new ones.
TEST(AppErrors, GlobalInnerFluidRatiosRefused) {
  expect_refused(kCavity, "--set fluid.viscosity_ratio=4",
                 "fluid.viscosity_ratio = 4.0 (from --set): the inner fluid is now given per capsule: set viscosity_ratio");
  expect_refused(std::string(kCavity) + "[fluid]\ndensity_ratio = 0.5\n", "",
                 "fluid.density_ratio = 0.5: the inner fluid is now given per capsule: set density_ratio");
}

// Solids are read and checked; embedded walls with carried faces are refused (they must not
// run as if the solid were not there).
TEST(AppErrors, SolidsAreCheckedAndRefusedWhereNotSupportedYet) {
  const std::string circle = "[[solid]]\nshape = \"sphere\"\ncentre = [0.5, 0.5]\nradius = ";
  expect_refused(kCavity + circle + "-0.2\n", "", "solid[0].radius = -0.2: must be > 0");
  expect_refused(kCavity + circle + "0.2\n", "--set fluid.carry_faces=true",
                 "solid[0]: embedded walls with fluid.carry_faces = true are not implemented yet");
}

// A capsule must start beyond its kernels' reach of every embedded wall (contact is not
// modelled): refused before any work, naming the capsule and the distance.
TEST(AppErrors, CapsuleStartingAtAnEmbeddedWallIsRefused) {
  expect_refused(test_cases::post_channel(-0.705), "", "capsule[0].centre: the membrane starts 0.005 from an embedded wall");
}

TEST(AppErrors, CapsuleThatDoesNotFit) {
  const std::string capsule = R"(name = "c"
[domain]
roots = [4, 1, 1]
root_size = 2.0
origin = [-4.0, -1.0, -1.0]
[fluid.boundary]
x_lo = { type = "wall" }
x_hi = { type = "outflow" }
y_lo = { type = "wall" }
y_hi = { type = "wall" }
z_lo = { type = "wall" }
z_hi = { type = "wall" }
[[capsule]]
radius = 0.85
centre = [0.0, 0.5, 0.0]
)";
  expect_refused(capsule, "", "capsule");
}

// An array index that does not fit any integer: exit 2 naming the key (it was exit 3 and
// the bare text "stoul").
TEST(AppErrors, OverrideIndexOutOfRange) {
  expect_refused(kCavity, "--set 'capsule[99999999999999999999999].radius=1'",
                 "case.toml: --set capsule[99999999999999999999999].radius=1: index 99999999999999999999999 in key");
}

TEST(AppErrors, BadCommandLineAndCorruptCheckpoint) {
  const fs::path dir = scratch("cli");
  const fs::path file = write(dir, "case.toml", kCavity);
  auto r = capsflow("run " + file.string() + " --adapt maybe", dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("--adapt"));
  r = capsflow("fly " + file.string(), dir);
  EXPECT_EQ(r.status, 2);
  // An empty path (a variable that expanded to nothing) is neither a fresh start nor out/.
  for (const char* empty : {" --restart ''", " --out ''"}) {
    r = capsflow("run " + file.string() + " --quiet" + empty, dir);
    EXPECT_EQ(r.status, 2) << empty << r.err;
    EXPECT_THAT(r.err, HasSubstr("the path is empty"));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  write(dir, "broken.h5", "not an HDF5 file");
  r = capsflow("run " + file.string() + " --out " + (dir / "o").string() + " --restart " + (dir / "broken.h5").string(), dir);
  EXPECT_EQ(r.status, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr("broken.h5"));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(AppErrors, HelpAndVersion) {
  const fs::path dir = scratch("help");
  EXPECT_EQ(capsflow("--version", dir).status, 0);
  EXPECT_EQ(capsflow("run --help", dir).status, 0);
}

}  // namespace
}  // namespace capsflow::app

namespace capsflow::app {
namespace {

// A run that blows up stops with exit status 3 and a message naming the step, the time and
// the likely cause; what it wrote before is kept.
TEST(AppErrors, BlowUpIsReportedAndOutputKept) {
  const fs::path dir = testing::scratch("blowup");
  const auto r = testing::capsflow(std::string("run ") + CAPSFLOW_CASES_DIR +
                                       "/cavity_2d.toml --quiet --set time.cfl=0 --set time.dt=0.5 "
                                       "--set time.t_end=100 --out " + (dir / "out").string(),
                                   dir);
  EXPECT_EQ(r.status, 3);
  EXPECT_THAT(r.err, ::testing::HasSubstr("the velocity is not finite"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("step "));
  EXPECT_THAT(r.err, ::testing::HasSubstr("time.cfl"));
  EXPECT_TRUE(fs::exists(dir / "out" / "fluid_000000.vtu"));
  EXPECT_TRUE(fs::exists(dir / "out" / "diagnostics.csv"));
}

}  // namespace
}  // namespace capsflow::app
