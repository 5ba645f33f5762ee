#pragma once
// `capsflow run`: a case file to a finished run directory.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace capsflow::app {

struct RunRequest {
  std::filesystem::path case_file;
  std::vector<std::string> overrides;  // --set key=value
  std::optional<bool> adapt;           // --adapt on|off
  std::optional<std::filesystem::path> out;
  std::optional<std::filesystem::path> restart;
  bool quiet = false;
  bool force = false;                  // --force: write over another run's folder
  std::optional<std::uint64_t> max_memory;  // --max-memory, bytes
};

// A run that started but could not finish (blow-up): the message names the step, the
// time and the likely cause; the output written so far is kept.
class RunFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws io::CaseError, io::CheckpointError, RequestError (output_dir.hpp) or
// std::invalid_argument for bad input (before anything is written), RunFailure for a run
// that blows up.
void run_case(const RunRequest& request);

}  // namespace capsflow::app
