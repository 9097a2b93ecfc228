// Adhesive normal law of the consolidation scene (physics.md section 6) as a small evaluator:
// elastic repulsion K_N delta, a constant attraction F0 while overlapping that fades linearly to zero
// over the gap range D0, and a viscous dashpot only while overlapping.
//
// The dashpot coefficient is c_n = 2 zeta sqrt(m* K_N), zeta from e_N as if F0 = 0. Combining a
// restitution-based damping with the adhesion itself diverges as the overlap goes to zero, so it is
// never done. The dashpot may pull: the total normal force is not clamped at zero (that is the point).
#pragma once
#include <algorithm>
#include <cmath>

#include "interactions/contact_step.hpp"

namespace grains {

struct AdhesiveContactLaw {
  static constexpr bool has_tail = true;
  double k = 0;                 // K_N (force / length)
  double attraction = 0;        // F0 (force); 0 = the cohesionless reference law
  double range = 0;             // D0 (length): attraction reaches zero at gap h = D0
  double damping_ratio = 0;     // zeta, from e_N
  double overlap_limit = 0.1;   // f_max: delta_used <= f_max * min(R_i, R_j)

  double reach() const { return range; }
  double stiffness(double, double) const { return k; }
  double damping(double mi, double mj) const { return 2 * damping_ratio * std::sqrt(mi * mj / (mi + mj) * k); }

  // Overlapping pair: force on j along n (positive = repulsive), with the sub-step treatment of
  // touching and of parting (contact_step.hpp; the attraction is continuous at h = 0, the elastic
  // force has a kink there and the dashpot jumps). `elastic` is the elastic part K_N delta that bounds friction and rolling.
  // cn: the pair's damping(mi, mj), which the caller has computed already (a root and a division).
  double force(const ContactStep& p, double, double, double cn, double rmin, double& elastic, bool& clamped) const {
    const double limit = overlap_limit * rmin;
    clamped = p.overlap > limit;
    elastic = k * (clamped ? limit : p.overlap);
    const Onset on = parting(p, onset(p));
    return elastic + k * on.extra_overlap - attraction - cn * p.vn * on.dashpot_weight;
  }

  // The part of force() that is the parting charge (contact_step.hpp, parting): taken back at the next
  // evaluation where the pair still overlaps (contact_forces.hpp), over that evaluation's whole kick window;
  // the initial evaluation's was charged over half a window, so half of it is taken back.
  double parting_charge(const ContactStep& p, double cn) const {
    const Onset start = onset(p), on = parting(p, start);
    const double charge = k * (on.extra_overlap - start.extra_overlap) - cn * p.vn * (on.dashpot_weight - start.dashpot_weight);
    return p.dt > 0 ? charge : 0.5 * charge;
  }

  // Open pair with gap 0 <= h < D0: the attraction fading linearly (no damping, no elastic part).
  double tail(double gap) const { return -attraction * (1 - gap / range); }

  // The elastic part K_N delta of an overlapping pair at rest, its overlap clamped as force() clamps it (rmin: the
  // pair's smaller radius): what the network's forces and the friction and rolling bounds take.
  double static_elastic(double overlap, double rmin) const { return k * std::min(overlap, overlap_limit * rmin); }

  // Static normal force (no dashpot) at gap h: what a contact network at rest carries, the force the law applies.
  double static_force(double gap, double rmin) const {
    if (gap < 0) return static_elastic(-gap, rmin) - attraction;
    return gap < range ? tail(gap) : 0.0;
  }

  // -dF_N/dh of the elastic law: K_N in contact (past the overlap clamp too, where the applied force stops
  // growing: the elastic moduli linearise the law, not the clamp, which marks a contact numerically extreme and is
  // counted), the tail's negative stiffness -F0 / D0 across a gap.
  double static_stiffness(double gap) const {
    if (gap < 0) return k;
    return gap < range ? -attraction / range : 0.0;
  }

  // Potential of the attraction (zero beyond D0): -F0 D0 / 2 (1 - h / D0)^2 in the tail,
  // -F0 D0 / 2 - F0 delta while overlapping.
  double adhesion_energy(double gap) const {
    if (gap >= range) return 0.0;
    if (gap >= 0) return -0.5 * attraction * range * (1 - gap / range) * (1 - gap / range);
    return -0.5 * attraction * range + attraction * gap;
  }
};

}  // namespace grains
