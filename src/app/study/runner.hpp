#pragma once
// Running a study's members: each as a child process of this binary (`capsflow run BASE
// --set ... --out DIR --quiet --force`, its output in DIR/run.log), up to `jobs` at once, so
// one member that fails does not stop the others. A member whose folder holds a finished
// run of the same case (DIR/study_done.txt and a case.toml equal to the member's) is skipped:
// an interrupted study resumes where it stopped.
#include <filesystem>
#include <string>
#include <vector>

#include "app/study/members.hpp"

namespace capsflow::app::study {

enum class MemberState { skipped, ran, failed, interrupted, not_run };

struct MemberOutcome {
  MemberState state = MemberState::not_run;
  int exit_status = 0;     // of the member's run
  std::string message;     // a failure's last line of run.log
  double run_s = 0.0;      // the run's process wall time (kept from the first run when skipped)
  double cpu_s = 0.0;      // its CPU time, user + system, all threads (less sensitive to a loaded machine)
};

struct RunnerOptions {
  std::filesystem::path members_dir;  // one folder per member inside
  int jobs = 1;
  bool quiet = false;
  bool rerun = false;                 // run finished members again
  std::filesystem::path executable;   // the binary members run (/proc/self/exe)
};

// The folder a member runs in.
[[nodiscard]] std::filesystem::path member_dir(const RunnerOptions& o, const Member& m);

// Runs (or skips) every member. Stops launching members after SIGINT or SIGTERM, passes the
// signal on to the running ones and waits for them (their outcome is then `interrupted`).
[[nodiscard]] std::vector<MemberOutcome> run_members(const std::vector<Member>& members, const RunnerOptions& o);

}  // namespace capsflow::app::study
