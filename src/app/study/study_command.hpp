#pragma once
// `capsflow study STUDY.toml`: run a ladder of members of a base case and report the
// convergence (docs/studies.md).
#include <CLI/CLI.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace capsflow::app::study {

struct StudyRequest {
  std::filesystem::path file;
  std::optional<std::filesystem::path> out;  // default out/studies/<name>
  std::vector<std::string> set;  // --set for every member, after the study's own
  int jobs = 1;
  bool quiet = false;
  bool plots = true;
  bool rerun = false;  // run every member again, finished or not
};

// Adds the subcommand and its options to the command line, filling `request`.
CLI::App* add_study_subcommand(CLI::App& cli, StudyRequest& request);

// Runs the study and returns the exit status: 0 done, 1 an [expect] line does not hold,
// 2 a bad study file or member case (one line on stderr), 3 a member failed (the others
// run and are reported), 128 + the signal after SIGINT or SIGTERM.
[[nodiscard]] int run_study(const StudyRequest& request);

}  // namespace capsflow::app::study
