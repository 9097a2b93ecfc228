#include "stop_signal.hpp"

#include <algorithm>
#include <csignal>

#include <signal.h>

namespace grains {
namespace {
volatile std::sig_atomic_t requested = 0;
void on_signal(int) { requested = 1; }
}  // namespace

void catch_stop_signals() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  // A closed terminal stops a run like Ctrl-C, unless it was started to outlive it (nohup: SIGHUP ignored).
  struct sigaction hangup {};
  if (sigaction(SIGHUP, nullptr, &hangup) == 0 && hangup.sa_handler != SIG_IGN) std::signal(SIGHUP, on_signal);
}

bool stop_requested() { return requested != 0; }

long stop_check_steps(std::size_t particles) {
  return std::clamp(2'000'000 / long(std::max<std::size_t>(particles, 1)), 1L, 4096L);
}

}  // namespace grains
