#include "stop_signal.hpp"

#include <csignal>

namespace grains {
namespace {
volatile std::sig_atomic_t requested = 0;
void on_signal(int) { requested = 1; }
}  // namespace

void catch_stop_signals() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

bool stop_requested() { return requested != 0; }

}  // namespace grains
