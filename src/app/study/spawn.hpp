#pragma once
// Starting a program without a shell (no quoting of paths), for the study's members and its
// plot script.
#include <sys/types.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace capsflow::app::study {

struct SpawnOptions {
  std::optional<std::filesystem::path> output;  // stdout and stderr to this file (truncated); else inherited
  std::vector<std::pair<std::string, std::string>> env_defaults;  // set in the child when not set already
};

// Starts args[0] (looked up in PATH when it has no '/') with args; returns its pid, or -1.
// A child that cannot start the program exits with status 127.
[[nodiscard]] pid_t spawn(std::vector<std::string> args, const SpawnOptions& options = {});

// spawn, then waits: the exit status, or -1 (not started, or killed by a signal).
[[nodiscard]] int run_to_end(std::vector<std::string> args, const SpawnOptions& options = {});

}  // namespace capsflow::app::study
