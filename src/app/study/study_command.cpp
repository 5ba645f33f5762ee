#include "app/study/study_command.hpp"

#include <fmt/format.h>

#include <unistd.h>

#include <cstdio>

#include "app/interrupt.hpp"
#include "app/study/members.hpp"
#include "app/study/plots.hpp"
#include "app/study/results.hpp"
#include "app/study/runner.hpp"
#include "io/errors.hpp"
#include "io/study_config.hpp"

namespace capsflow::app::study {

namespace {

namespace fs = std::filesystem;

int bad_input(const std::string& line) {
  std::fprintf(stderr, "capsflow: %s\n", line.c_str());
  return 2;
}

// The table a user reads at the end: one line per member.
void print_summary(const io::StudyConfig& s, const std::vector<Member>& members,
                   const std::vector<MemberOutcome>& outcomes, const std::vector<MemberResult>& results,
                   const fs::path& dir) {
  std::printf("%-36s %-8s %11s %11s %11s %11s %11s %10s %9s\n", "member", "status", "N_inf", "vmax", "area_rel",
              "volume_rel", "D12_err", "cells", "wall_s");
  for (std::size_t i = 0; i < members.size(); ++i) {
    const MemberResult& r = results[i];
    const char* state = outcomes[i].state == MemberState::skipped ? "skipped"
                        : r.available                             ? "ran"
                                                                  : "missing";
    if (!r.available) {
      std::printf("%-36s %-8s %s\n", members[i].name.c_str(), state, r.problem.c_str());
      continue;
    }
    std::printf("%-36s %-8s %11.4e %11.4e %+11.3e %+11.3e %11.4e %10.0f %9.1f\n", members[i].name.c_str(), state,
                r.N_inf, r.vmax, r.area_rel, r.volume_rel, r.D12_err, r.cells_mean, r.wall_s);
  }
  std::printf("study %s: %s/study.csv, orders.csv, equal_error.csv\n", s.name.c_str(), dir.c_str());
}

}  // namespace

CLI::App* add_study_subcommand(CLI::App& cli, StudyRequest& r) {
  auto* sub = cli.add_subcommand("study", "Run a convergence study: a ladder of members of a base case, "
                                          "study.csv and plots (docs/studies.md)");
  sub->add_option("study", r.file, "Study file (TOML; docs/studies.md)")->required();
  sub->add_option("--out", r.out, "Study folder (default out/studies/<name>); members in <out>/members/");
  sub->add_option("--set", r.set, "Override a key of every member's case after the study's set (repeatable), "
                                  "e.g. --set time.t_end=0.05 for a shorter study")
      ->type_name("KEY=VALUE");
  sub->add_option("--jobs", r.jobs, "Members run at once (default 1)")->check(CLI::Range(1, 256));
  sub->add_flag("--quiet", r.quiet, "No progress line");
  sub->add_flag("!--no-plots", r.plots, "Write the CSV files only");
  sub->add_flag("--rerun", r.rerun, "Run every member again, even those a previous run of the study finished");
  return sub;
}

int run_study(const StudyRequest& req) {
  io::StudyConfig s;
  std::vector<Member> members;
  try {
    s = io::parse_study(req.file);
    s.set.insert(s.set.end(), req.set.begin(), req.set.end());
    members = expand_members(s);
  } catch (const io::CaseError& e) {
    return bad_input(e.what());
  }
  const fs::path dir = req.out ? *req.out : fs::path("out") / "studies" / s.name;
  RunnerOptions o{.members_dir = dir / "members", .jobs = req.jobs, .quiet = req.quiet, .rerun = req.rerun,
                  .executable = "/proc/self/exe"};
  std::error_code ec;
  // Members run /proc/self/exe: this very binary even if a rebuild replaces the file meanwhile.
  // Its path (for the plot script next to it) is read now, before such a rebuild.
  const fs::path binary = fs::read_symlink(o.executable, ec);
  if (ec) return bad_input(fmt::format("cannot find this binary ({}): {}", o.executable.string(), ec.message()));
  fs::create_directories(o.members_dir, ec);
  if (ec || access(dir.c_str(), W_OK) != 0)
    return bad_input(fmt::format("{}: cannot create or write the study folder{}", dir.string(),
                                 ec ? ": " + ec.message() : ""));

  install_interrupt_handlers();
  const std::vector<MemberOutcome> outcomes = run_members(members, o);
  const std::vector<MemberResult> results = read_results(s, members, o);
  const std::vector<std::string> failures = write_results(s, members, outcomes, results, dir);
  print_summary(s, members, outcomes, results, dir);
  if (interrupt_signal() != 0) {
    std::fprintf(stderr, "capsflow: study %s stopped by signal %d; run the same command again to resume\n",
                 s.name.c_str(), interrupt_signal());
    return 128 + interrupt_signal();
  }
  if (req.plots) (void)make_plots(dir, binary);
  int failed = 0;
  for (const MemberOutcome& m : outcomes) failed += m.state == MemberState::failed;
  for (const std::string& f : failures) std::fprintf(stderr, "capsflow: study expectation failed: %s\n", f.c_str());
  if (failed > 0) {
    std::fprintf(stderr, "capsflow: study %s: %d member(s) failed (their run.log in %s)\n", s.name.c_str(), failed,
                 o.members_dir.c_str());
    return 3;
  }
  return failures.empty() ? 0 : 1;
}

}  // namespace capsflow::app::study
