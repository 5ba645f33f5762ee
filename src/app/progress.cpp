#include "app/progress.hpp"

#include <unistd.h>

#include <atomic>
#include <cstdio>

#include <fmt/format.h>

namespace capsflow::app {

namespace {
std::atomic<bool> g_line_open{false};  // one progress line per process
}  // namespace

bool progress_line_open() { return g_line_open; }

ProgressLine::ProgressLine(bool quiet)
    : quiet_(quiet), terminal_(isatty(fileno(stderr)) != 0), start_(std::chrono::steady_clock::now()),
      last_print_(start_) {}

void ProgressLine::update(const ProgressState& s, bool force) {
  if (quiet_) return;
  const auto now = std::chrono::steady_clock::now();
  if (first_step_ < 0) {
    first_step_ = s.step - 1;  // the step before the first one of this run
    first_t_ = s.t - s.dt;  // the time this run started from (a restart starts late)
  }
  if (!force && !due()) return;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double rate = elapsed > 0 ? double(s.step - first_step_) / elapsed : 0.0;
  const double fraction = s.t_end > 0 ? s.t / s.t_end : 1.0;
  // The remaining time at the rate of this run (not of the run a restart resumed).
  const double done = s.t - first_t_;
  const double eta = done > 0 ? elapsed * (s.t_end - s.t) / done : 0.0;
  print(fmt::format("step {}  t {:.4g}/{:.4g} ({:.0f}%)  dt {:.2e}  cells {}  level {}  mg {}  "
                    "{:.1f} steps/s  ETA {}",
                    s.step, s.t, s.t_end, 100 * fraction, s.dt, s.cells, s.max_level, s.mg_cycles, rate, hms(eta)));
}

std::string hms(double seconds) {
  const auto s = static_cast<long>(seconds);
  return fmt::format("{}:{:02d}:{:02d}", s / 3600, (s / 60) % 60, s % 60);
}

void ProgressLine::show(std::string line, bool force) {
  if (quiet_ || (!force && !due())) return;
  print(std::move(line));
}

bool ProgressLine::due() const {
  const double since = std::chrono::duration<double>(std::chrono::steady_clock::now() - last_print_).count();
  return since >= (terminal_ ? 0.2 : 5.0);
}

void ProgressLine::print(std::string line) {
  last_print_ = std::chrono::steady_clock::now();
  if (terminal_) {
    const std::size_t width = line.size();
    if (width < last_width_) line.append(last_width_ - width, ' ');
    last_width_ = width;
    std::fprintf(stderr, "\r%s", line.c_str());
    g_line_open = true;
  } else {
    std::fprintf(stderr, "%s\n", line.c_str());
  }
  std::fflush(stderr);
}

void ProgressLine::finish() {
  if (g_line_open.exchange(false)) std::fprintf(stderr, "\n");
}

}  // namespace capsflow::app
