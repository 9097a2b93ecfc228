// One contact event of the collision log (analysis/collision_events.hpp): plain data, shared by the
// log, the Simulation seam and the writers.
#pragma once
#include <cstdint>

namespace grains {

struct CollisionEvent {
  std::uint32_t i = 0, j = 0;
  double start = 0, end = 0;   // touching and end times (touching/separation interpolated within the step)
  double impact_speed = 0;     // -v_n in the last step before touching (>= 0)
  double rebound_speed = 0;    // v_n when the surfaces separate; 0 for an adhesive collision
  std::uint64_t adhesive = 0;   // 0 or 1 (a full word: the record has no padding bytes, so saved states compare bitwise)
};

}  // namespace grains
