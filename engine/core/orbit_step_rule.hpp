// Gravity time-step rule (physics.md section 3): the fastest orbit the softened potential allows is the circular
// one of the two heaviest particles at their closest approach d, T_orb = 2 pi sqrt((d^2 + eps^2)^(3/2) / (G (m_1 + m_2))),
// and a step above T_orb / 20 resolves it with fewer than 20 steps.
// The closest approach is the contact distance 2 R_min only where the contacts surely keep grains apart, and a capped
// contact force need not: beyond delta_max = contact.overlap_limit R_min it stays k_n delta_max (physics.md section
// 2), and a larger pull sinks the grains into each other down to the softened centre (at k* = 10, two grains passed
// through each other and gained 18 times their kinetic energy, with no warning while d was 2 R_min). Bound the pull
// on one grain by the whole system's mass at contact distance, G m_max M / (2 R_min)^2: a capped force above it keeps
// d = 2 R_min, else d = 0 (then T_orb depends on eps alone). The bound is generous, so d = 0 is the usual case: the
// default aggregation scene's capped force, 647, is below its bound, 1000, and its step is 3.7 times below T_orb / 20
// at d = 0.
// The inputs are the scene's and fixed for a run; G is not (a host may change the tunable gravity.G between steps),
// so the rule is kept as its inputs and evaluated at the G in effect.
#pragma once
#include "core/softened_core.hpp"

namespace grains {

struct OrbitStepRule {
  double pair_mass = 0;   // m_1 + m_2 of the two heaviest grains
  double heaviest = 0;    // m_max
  double total = 0;       // M, the whole system's mass
  double eps = 0;         // the softening length
  double capped = 0;      // k_n delta_max, the capped contact force of the lightest (softest) pair; 0 without contacts
  double rmin = 0;        // R_min
  bool contacts = false;

  struct At {
    double pull = 0;    // G m_max M / (2 R_min)^2
    bool held = false;  // the capped force exceeds the pull: contacts keep grains 2 R_min apart
    double d = 0;       // the closest approach
    double orbit = 0;   // T_orb (0: unsoftened point masses, no bound)
    double step() const { return orbit / 20; }
  };

  At at(double G) const {
    At r;
    r.pull = G * heaviest * total / (4 * rmin * rmin);
    r.held = contacts && capped > r.pull;
    r.d = r.held ? 2 * rmin : 0.0;
    r.orbit = softened_orbit_period(G, pair_mass, eps, r.d);
    return r;
  }
};

}  // namespace grains
