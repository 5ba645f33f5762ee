#include "app/interrupt.hpp"

#include <signal.h>

#include <csignal>
#include <cstring>

#include <fmt/format.h>

namespace capsflow::app {

namespace {

// Written by the handler, read by the time loop: sig_atomic_t is what a handler may set.
volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int signal) { g_signal = signal; }

const char* signal_name(int signal) {
  switch (signal) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    default:
      return "a signal";
  }
}

}  // namespace

void install_interrupt_handlers() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  // SA_RESETHAND: the default action is back after the first signal, so a second one kills
  // at once. SA_RESTART: reads and writes in progress carry on instead of failing (EINTR).
  action.sa_flags = SA_RESETHAND | SA_RESTART;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

int interrupt_signal() { return g_signal; }

Interrupted::Interrupted(int signal, long step, double time, const std::filesystem::path& checkpoint)
    : std::runtime_error(
          fmt::format("interrupted by {} after step {} (t = {:.6g}); checkpoint written to {}; "
                      "continue with --restart {}",
                      signal_name(signal), step, time, checkpoint.string(), checkpoint.string())),
      signal_(signal) {}

}  // namespace capsflow::app
