// Linear spring-dashpot normal law (physics.md section 2) as a small evaluator: parameters + one
// function of the pair's step. The dashpot may not pull; overlaps are clamped.
#pragma once
#include <algorithm>

#include "interactions/contact_step.hpp"

namespace grains {

template <bool PerPair>
struct LinearContactLaw {
  // Global mode: k, c are the stiffness and damping. Per-pair mode: per unit reduced mass.
  double k = 0, c = 0;
  double overlap_limit = 0.1;   // f_max: delta_used <= f_max * min(R_i, R_j)

  static constexpr bool has_tail = false;   // no interaction beyond contact
  double reach() const { return 0.0; }
  double stiffness(double mi, double mj) const { return PerPair ? k * mi * mj / (mi + mj) : k; }
  double damping(double mi, double mj) const { return PerPair ? c * mi * mj / (mi + mj) : c; }

  // Force on j along n (positive = repulsive), with the sub-step treatment of touching and of the
  // clamp release (contact_step.hpp). `elastic`: k delta_used, which bounds friction.
  // cn: the pair's damping(mi, mj), which the caller has computed already.
  double force(const ContactStep& p, double mi, double mj, double cn, double rmin, double& elastic, bool& clamped) const {
    const double kn = stiffness(mi, mj);
    const double limit = overlap_limit * rmin;
    clamped = p.overlap > limit;
    const double used = clamped ? limit : p.overlap;
    elastic = kn * used;
    const Onset on = onset(p);
    double f = elastic + kn * on.extra_overlap - cn * p.vn * on.dashpot_weight;
    // Released within two steps? Only a separating pair (v_n > 0) can be: k delta = c v_n at release.
    // The fall over a step is -f' h, f' = k delta' - c v_n' with delta' = -v_n and, for the pair alone,
    // v_n' = f / m*; tested times mi mj, without a division.
    if (!clamped && f > 0 && p.vn > 0) {
      const bool initial = p.dt <= 0;
      const double mm = mi * mj, slope = kn * p.vn * mm + cn * f * (mi + mj);
      if (initial) {
        // The initial evaluation is charged over [0, h/2] only: released sigma < 1 of the first step ahead,
        // the force's exact impulse f sigma h / 2 is that window's times sigma (released later: the next
        // evaluation's correction spreads it). Without it: 5.2e-4 too fast at sigma = 0.5, n_c = 50.
        const double fall = p.first_step * slope;
        if (f * mm < fall) f *= f * mm / fall;
      } else if (!p.first) {
        const double fall = p.dt * slope;
        if (f * mm < 2 * fall) f += release_force(f, fall / mm);
      }
    }
    return std::max(0.0, f);
  }
};

}  // namespace grains
