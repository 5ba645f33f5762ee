// Runs that cannot fit in memory are refused before they allocate, a signal ends a run with
// a checkpoint to restart from, and failure messages say what went wrong (issue 15).
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
  for (const std::string& args : {quick("--adapt off --set adapt.max_level=12"),
                                  "run " + std::string(CAPSFLOW_CASES_DIR) +
                                      "/duct_3d.toml --quiet --set domain.roots=[1000,1000,1000]",
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

// A run that passes the estimate but still runs out says so, with status 3, instead of
// "std::bad_alloc": an adaptive run (the estimate counts its coarsest grid) refining one
// level per step everywhere (a tolerance nothing meets) under a 400 MB address-space limit.
TEST(AppLimits, OutOfMemoryIsReported) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves more address space than the limit";
#endif
  const fs::path dir = scratch("oom");
  const std::string cmd = "ulimit -v 400000; OMP_NUM_THREADS=1 " + std::string(CAPSFLOW_BINARY) + " " +
                          cavity("--set adapt.min_level=7 --set adapt.max_level=11 --set adapt.interval=1 "
                                 "--set adapt.velocity_tolerance=1e-12 --out " +
                                 (dir / "out").string()) +
                          " 2> " + (dir / "err.txt").string();
  const int raw = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(raw));
  EXPECT_EQ(WEXITSTATUS(raw), 3);
  const std::string err = slurp(dir / "err.txt");
  EXPECT_THAT(err, StartsWith("capsflow: out of memory"));
  EXPECT_EQ(lines(err), 1) << err;
}

// The address-space limit (ulimit -v) counts as a memory limit: a uniform grid that cannot
// fit under it is refused up front (status 2, the estimate), not after minutes of work.
TEST(AppLimits, AddressSpaceLimitRefusesUpFront) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer reserves more address space than the limit";
#endif
  const fs::path dir = scratch("ulimit");
  const std::string cmd = "ulimit -v 400000; OMP_NUM_THREADS=1 " + std::string(CAPSFLOW_BINARY) + " " +
                          cavity("--adapt off --set adapt.max_level=11 --out " + (dir / "out").string()) +
                          " 2> " + (dir / "err.txt").string();
  const int raw = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(raw));
  EXPECT_EQ(WEXITSTATUS(raw), 2);
  const std::string err = slurp(dir / "err.txt");
  EXPECT_THAT(err, HasSubstr("ulimit -v"));
  EXPECT_EQ(lines(err), 1) << err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// Starts capsflow in the background (one thread, stderr to a file); returns its pid.
pid_t spawn(const std::string& args, const fs::path& err) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const std::string cmd = "exec env OMP_NUM_THREADS=1 " + std::string(CAPSFLOW_BINARY) + " " + args +
                            " > /dev/null 2> " + err.string();
    ::execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  return pid;
}

// SIGTERM: the run finishes its step, writes a checkpoint (output.checkpoint is off), says
// where, exits with 128 + 15, leaves no temporary file, and restarts from the checkpoint.
TEST(AppLimits, SignalWritesACheckpointAndExits) {
  const fs::path dir = scratch("signal");
  const fs::path out = dir / "out";
  const std::string args = cavity("--set time.t_end=1000 --set output.interval=20 --out " + out.string());
  const pid_t pid = spawn(args, dir / "err.txt");
  ASSERT_GT(pid, 0);
  for (int i = 0; i < 600 && !fs::exists(out / "fluid_000000.vtu"); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_TRUE(fs::exists(out / "fluid_000000.vtu"));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a few snapshots later
  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  const std::string err = slurp(dir / "err.txt");
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM) << err;
  std::vector<fs::path> checkpoints;
  for (const auto& e : fs::directory_iterator(out)) {
    const std::string name = e.path().filename().string();
    EXPECT_NE(name[0], '.') << "temporary file left: " << name;
    if (name.starts_with("checkpoint_")) checkpoints.push_back(e.path());
  }
  ASSERT_EQ(checkpoints.size(), 1u);
  EXPECT_THAT(err, HasSubstr(checkpoints[0].string()));
  EXPECT_THAT(err, HasSubstr("SIGTERM"));
  // Restart in the same folder for two more steps.
  const long step = std::stol(checkpoints[0].stem().string().substr(11));
  const auto r = capsflow(cavity("--set output.diagnostics_interval=1 --set time.t_end=" +
                                 std::to_string(0.005 * double(step + 2)) + " --out " + out.string() +
                                 " --restart " + checkpoints[0].string()),
                          dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string csv = slurp(out / "diagnostics.csv");
  EXPECT_THAT(csv, HasSubstr("\n" + std::to_string(step + 2) + ","));
}

// Status-3 messages start on their own line only when a progress line is on the terminal
// (stderr here is a file); unreadable files and directories are named as such.
TEST(AppLimits, FailureMessagesSayWhatHappened) {
  const fs::path dir = scratch("messages");
  auto r = capsflow(cavity("--set time.dt=0.5 --set time.t_end=100 --out " + (dir / "blow").string()), dir);
  EXPECT_EQ(r.status, 3);
  // (the solves of a blowing-up run miss their tolerance first: one warning line)
  EXPECT_THAT(r.err, AnyOf(StartsWith("capsflow: "), HasSubstr("(warned once)\ncapsflow: ")));
  EXPECT_THAT(r.err, Not(HasSubstr("\n\n")));
  r = capsflow("run /proc/self/mem --quiet --out " + (dir / "mem").string(), dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("cannot read"));
  EXPECT_THAT(r.err, Not(HasSubstr("missing")));
  r = capsflow(cavity("--out " + (dir / "o").string() + " --restart " + dir.string()), dir);
  EXPECT_EQ(r.status, 2);
  EXPECT_THAT(r.err, HasSubstr("is a directory"));
}

}  // namespace
}  // namespace capsflow::app
