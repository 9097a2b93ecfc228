// Linear spring-dashpot normal law (physics.md section 2) as a small evaluator: parameters + one
// function of the pair's overlap and normal velocity. The dashpot may not pull; overlaps are clamped.
#pragma once
#include <algorithm>

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

  // Force on j along n (positive = repulsive). vn: normal relative velocity (negative = approaching),
  // the predicted value at the end of the step; overlap_before: the overlap at the start of the step.
  //
  // Sub-step onset: the dashpot force jumps from 0 to -c vn when the surfaces touch, so a plain
  // step would charge it for the whole step or not at all (a first-order error in e). In a contact's
  // first step the dashpot is weighted by the share of its kick window [t - h/2, t + h/2] (plus the
  // half window the previous kick missed) that lies after the touching time, found by linear
  // interpolation of the overlap: w = 3/2 - s, s = share of the step before touching.
  double force(double overlap, double overlap_before, double vn, double mi, double mj, double rmin,
               double& elastic, bool& clamped) const {
    const double mstar = PerPair ? mi * mj / (mi + mj) : 1.0;
    const double limit = overlap_limit * rmin;
    clamped = overlap > limit;
    const double used = clamped ? limit : overlap;
    elastic = k * mstar * used;
    double w = 1.0;
    if (overlap_before <= 0) w = 1.5 + overlap_before / (overlap - overlap_before);
    return std::max(0.0, elastic - c * mstar * vn * w);
  }
};

}  // namespace grains
