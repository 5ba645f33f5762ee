// Runs that cannot fit in memory are refused before they allocate (issue 15).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "app_support.hpp"

namespace capsflow::app {
namespace {

using namespace testing;
using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;

long lines(const std::string& s) { return std::count(s.begin(), s.end(), '\n'); }

std::string quick(const std::string& extra) {
  return "run " + std::string(CAPSFLOW_CASES_DIR) + "/relaxation_quick.toml --quiet " + extra;
}
std::string cavity(const std::string& extra) {
  return "run " + std::string(CAPSFLOW_CASES_DIR) +
         "/cavity_2d.toml --quiet --set time.cfl=0 --set time.dt=0.005 --set time.t_end=0.02 " + extra;
}

// Grids far beyond any machine are refused at once with the estimate, before allocating
// (they used to grow to several GB and die of std::bad_alloc with status 3).
TEST(AppLimits, MemoryBombsAreRefusedWithTheEstimate) {
  const fs::path dir = scratch("memory");
  const auto start = std::chrono::steady_clock::now();
  for (const std::string args : {quick("--adapt off --set adapt.max_level=12"),
                                 "run " + std::string(CAPSFLOW_CASES_DIR) + "/duct_3d.toml --quiet --set domain.roots=[1000,1000,1000]",
                                 cavity("--max-memory 1M")}) {
    const auto r = capsflow(args + " --out " + (dir / "out").string(), dir);
    EXPECT_EQ(r.status, 2) << args << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("memory estimate"));
    EXPECT_EQ(lines(r.err), 1) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out")) << "refused before the output folder is made";
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 20.0);
  EXPECT_EQ(capsflow(cavity("--max-memory 4G --out " + (dir / "ok").string()), dir).status, 0);
  const auto bad = capsflow(cavity("--max-memory lots --out " + (dir / "bad").string()), dir);
  EXPECT_EQ(bad.status, 2);
  EXPECT_THAT(bad.err, HasSubstr("--max-memory"));
}

}  // namespace
}  // namespace capsflow::app
