#pragma once
// The run's progress on standard error: one line that rewrites itself on a terminal, plain
// lines every few seconds otherwise (logs, CI), nothing with --quiet.
#include <chrono>
#include <string>

namespace capsflow::app {

struct ProgressState {
  long step = 0;
  double t = 0.0, t_end = 0.0, dt = 0.0;
  long cells = 0;
  int max_level = 0;
  int mg_cycles = 0;
};

// True while a progress line is on the terminal without its newline: a message printed then
// must start on a new line (and only then: with --quiet or into a log the line is complete).
[[nodiscard]] bool progress_line_open();

// A duration as h:mm:ss (whole seconds).
[[nodiscard]] std::string hms(double seconds);

class ProgressLine {
 public:
  explicit ProgressLine(bool quiet);
  void update(const ProgressState& s, bool force = false);
  // Any line (a study's, app/study/runner.cpp), shown like update's: at most every 0.2 s on
  // a terminal (rewriting itself) and every 5 s otherwise, unless forced.
  void show(std::string line, bool force = false);
  void finish();

 private:
  [[nodiscard]] bool due() const;  // enough time since the last line
  void print(std::string line);
  bool quiet_;
  bool terminal_;
  std::chrono::steady_clock::time_point start_, last_print_;
  long first_step_ = -1;
  double first_t_ = 0.0;
  std::size_t last_width_ = 0;
};

}  // namespace capsflow::app
