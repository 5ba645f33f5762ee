#pragma once
// Ending a run with SIGINT (Ctrl-C) or SIGTERM (a batch system's time limit) without losing
// it: the first signal only sets a flag; the time loop finishes its step, writes a
// checkpoint and stops (exit status 128 + the signal: 130 for SIGINT, 143 for SIGTERM, as a
// shell reports a killed command). The handler is reset by the first signal, so a second
// one ends the process at once.
#include <filesystem>
#include <stdexcept>

namespace capsflow::app {

// Installs the handlers for SIGINT and SIGTERM (once per run).
void install_interrupt_handlers();

// The signal that asked the run to stop, or 0.
[[nodiscard]] int interrupt_signal();

// Thrown by the time loop after writing `checkpoint`; main reports it and exits with
// exit_status().
class Interrupted : public std::runtime_error {
 public:
  Interrupted(int signal, long step, double time, const std::filesystem::path& checkpoint);
  [[nodiscard]] int exit_status() const { return 128 + signal_; }

 private:
  int signal_;
};

}  // namespace capsflow::app
