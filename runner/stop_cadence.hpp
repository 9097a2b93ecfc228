// How many steps a run takes between reads of the stop request (Ctrl-C, SIGTERM): set by how long steps
// take, not by the particle count, since a step's cost differs by orders of magnitude between scenes (direct
// gravity's N^2 pairs against a gas's N). Chunks of steps run exactly as the whole (Simulation::step_n), so
// the cadence changes when a stop is seen, never the results.
#pragma once
#include <algorithm>

namespace grains {

class StopCadence {
 public:
  static constexpr long max_steps = 4096;
  static constexpr double aim_seconds = 0.1;   // a chunk's wall time: a stop is seen within a few tenths of a second

  long steps() const { return steps_; }

  // A chunk of `steps` steps took `seconds`: the next one aims at aim_seconds, growing at most twofold (one
  // fast chunk, as a cache warms up, says little) and shrinking at once.
  void ran(long steps, double seconds) {
    if (steps <= 0) return;
    const double per_step = std::max(seconds, 0.0) / double(steps);
    const double fit = per_step > 0 ? aim_seconds / per_step : double(max_steps);
    steps_ = std::clamp(long(std::min(fit, 2.0 * double(std::max(steps, steps_)))), 1L, max_steps);
  }

 private:
  long steps_ = 1;   // the first chunk is one step, whatever it costs
};

}  // namespace grains
