// The stop request's cadence: chunks of steps that take about a tenth of a second whatever a step costs.
#include <catch2/catch.hpp>

#include "stop_cadence.hpp"

using grains::StopCadence;

namespace {
// Runs chunks of steps costing `step_seconds` each; returns the longest chunk's wall time after the first few.
double longest_chunk(double step_seconds, long& steps_reached) {
  StopCadence c;
  double longest = 0;
  for (int k = 0; k < 40; ++k) {
    const long n = c.steps();
    const double seconds = double(n) * step_seconds;
    if (k >= 1) longest = std::max(longest, seconds);
    c.ran(n, seconds);
  }
  steps_reached = c.steps();
  return longest;
}
}  // namespace

TEST_CASE("stop cadence: chunks take about a tenth of a second, from a gas's steps to direct gravity's", "[runner]") {
  long steps = 0;
  // Direct gravity on 2000 particles, about 2 ms a step: the particle-step rule (2e6 / N = 1000 steps) made
  // a chunk 2 s long, and Ctrl-C waited that long.
  CHECK(longest_chunk(2e-3, steps) <= 0.2);
  CHECK(steps == 50);
  // A step of 1 s: every chunk is one step.
  CHECK(longest_chunk(1.0, steps) == 1.0);
  CHECK(steps == 1);
  // A cheap step (1 us): chunks grow to the cap, doubling.
  CHECK(longest_chunk(1e-6, steps) <= StopCadence::max_steps * 1e-6);
  CHECK(steps == StopCadence::max_steps);
}

TEST_CASE("stop cadence: grows at most twofold, shrinks at once, ignores empty chunks", "[runner]") {
  StopCadence c;
  c.ran(1, 1e-9);
  CHECK(c.steps() == 2);
  c.ran(2, 1e-9);
  CHECK(c.steps() == 4);
  c.ran(4, 4.0);   // a slow chunk: one step now
  CHECK(c.steps() == 1);
  c.ran(0, 0.0);
  CHECK(c.steps() == 1);
  c.ran(1, 0.0);   // a clock that did not tick: grow, no division by zero
  CHECK(c.steps() == 2);
}
