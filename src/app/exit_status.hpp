#pragma once
// What a run's failure means for the process (DESIGN.md, "What the user sees"): the exit
// status of each kind of error, its one-line message, and whether every rank of a
// distributed run meets the same error at the same point (so each can exit with it) or
// only this one does (so it must stop the others).
#include <exception>
#include <stdexcept>
#include <string>

namespace capsflow::app {

// Thrown on the ranks other than 0 when rank 0 failed in work only it does (writing
// output, reading the output folder): exit with `status`, rank 0 says why.
class OtherRankFailed : public std::runtime_error {
 public:
  explicit OtherRankFailed(int status) : std::runtime_error("failed on rank 0"), status_(status) {}
  [[nodiscard]] int status() const { return status_; }

 private:
  int status_;
};

struct ExitStatus {
  int status = 0;         // 2 bad input, 3 a failed run, 128 + signal after an interrupt
  std::string message;    // empty when another rank reports it
  bool collective = true;  // every rank meets this error where this one did
};

// The status and message of the exception in flight; `case_file` prefixes messages of
// std::invalid_argument (option validation names the key, not the file).
[[nodiscard]] ExitStatus exit_status_of(const std::exception_ptr& error, const std::string& case_file);

}  // namespace capsflow::app
