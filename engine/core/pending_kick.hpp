// The second half kick of a step, left pending while a run of steps goes on (Simulation::step_n): the
// next step's first pass over the particles does it (core/integrator.hpp), so the velocities, forces and
// spins stream through the caches once per step instead of twice. Between runs nothing is pending:
// every value a host or a file sees, and every saved state, is the kicked one, and the results are
// bit-identical to kicking at the end of each step (the same operations on each particle, in the same order).
// A velocity about to change between steps (a contact's onset correction, contact_forces.hpp) has its
// particle kicked first (kick_early); the next pass then leaves that particle's kick out.
#pragma once
#include <cstdint>
#include <vector>

namespace grains {

struct PendingKick {
  bool active = false;   // a kick is pending
  double h = 0;          // the length of the step it ends
  double keep = 1;       // that step's drag factor (integrator.hpp, kick)
  bool spins = false;    // it kicks the spins too
  std::vector<std::uint32_t> early;   // particles already kicked (kick_early), in the order they were
  std::vector<std::uint8_t> kicked;   // per particle: 1 if in `early`
  double early_witness = 0;           // the sum of their kicked velocities and spins
};

}  // namespace grains
