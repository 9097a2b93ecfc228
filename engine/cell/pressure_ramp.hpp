// A continuous ramp of the barostat's target pressure (cell.pressure_final, cell.ramp_duration): from the
// scene's P* to the final one over the ramp's duration, then held. Geometric (a straight line in log P*,
// as the paper's ladder of 10^(1/8) steps) when both ends are positive, linear when one is zero. The
// target changes a little every step, as the stress does, so CVODE keeps its history (a new target set by
// a host restarts it instead).
#pragma once
#include <algorithm>
#include <cmath>

namespace grains {

struct PressureRamp {
  double from = 0, to = 0;          // P* at the start and at the end
  double start = 0, duration = 0;   // simulated time
  bool on = false;                  // still driving the target (a host's cell.pressure ends it)

  double at(double t) const {
    const double f = std::clamp((t - start) / duration, 0.0, 1.0);
    if (f == 1.0) return to;
    return from > 0 && to > 0 ? from * std::pow(to / from, f) : from + (to - from) * f;
  }
  bool ended(double t) const { return t >= start + duration; }
};

}  // namespace grains
