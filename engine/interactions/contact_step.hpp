// What a normal law sees of one pair in one step, and the sub-step treatment of the instants where
// its force is not smooth (touching, and for the non-pulling law the clamp release), shared by the
// normal laws. Velocity Verlet charges the force at t over the kick window [t - h/2, t + h/2]: exact
// to second order for a smooth force, but a jump costs a first-order error and a kink (a force that
// starts or stops growing linearly) a second-order one whose coefficient, relative to a small
// rebound speed, dominates at low e.
#pragma once
#include <algorithm>

namespace grains {

struct ContactStep {
  double overlap;          // at the end of the step (now), > 0
  double overlap_before;   // at the start of the step (exact: x - h v(t + h/2))
  double vn;               // predicted normal relative velocity at the end of the step (negative = approaching)
  double dt;               // length of the step (0 for the initial force evaluation)
  bool first;              // the pair did not overlap at the previous force evaluation
  double first_step = 0;   // read at the initial evaluation (dt = 0) only: the step to come, of whose first half it is charged
};

// A contact's first step. Touching at share s of the step (linear interpolation of the overlap, exact
// before contact), the dashpot force -c v_n switches on: it is weighted by the part of the kick
// window after touching plus the half window the previous kick missed, w = 3/2 - s. The elastic
// force k delta starts growing linearly: the kicks miss k |v_n| h^2 (1 - 2s)^2 / 8 of its impulse
// (the midpoint rule on a kink), charged here as an extra overlap (delta - delta_before)(1 - 2s)^2 / 8.
// Not a first step, or the initial evaluation (no window before it): w = 1, nothing extra.
struct Onset {
  double dashpot_weight = 1.0;
  double extra_overlap = 0.0;
};
// The share s of a first step at which the surfaces touched (linear in free flight).
inline double touch_share(const ContactStep& p) {
  const double growth = std::max(0.0, p.overlap - p.overlap_before);
  // Touching within rounding of the step's start can leave overlap_before a hair above 0: s = 0.
  return growth > 0 ? std::clamp(-p.overlap_before / growth, 0.0, 1.0) : 0.0;
}
inline Onset onset(const ContactStep& p) {
  if (!p.first || p.dt <= 0) return {};
  const double growth = std::max(0.0, p.overlap - p.overlap_before), s = touch_share(p);
  return {1.5 - s, growth * (1 - 2 * s) * (1 - 2 * s) / 8};
}

// The contact's first drift ran at the pre-contact velocity u = -v_n: from touching, the dashpot would
// have slowed the pair over the rest of the step, tau = (1 - s) h, so the pair ends the step deeper
// than the exact solution by lag = (c / m*) u tau^2 / 2. Not correcting it shifts the whole contact in
// time: the restitution does not see that, the duration does (2.7e-3 at e = 0.01, n_c = 50). The
// caller evaluates the law at overlap - lag and moves the pair apart by lag (contact_forces.hpp).
inline double onset_lag(const ContactStep& p, double damping_per_reduced_mass) {
  if (!p.first || p.dt <= 0 || p.vn >= 0) return 0.0;
  const double tau = (1 - touch_share(p)) * p.dt;
  return 0.5 * damping_per_reduced_mass * -p.vn * tau * tau;
}

// Parting of the adhesive law, whose dashpot acts only while overlapping: a separating pair (v_n > 0)
// whose overlap runs out sigma < 1 steps ahead (predicted from v_n) will be open at the next
// evaluation, so this step's kick window is the contact's last. The dashpot force jumps to zero at
// parting: it acts for the half window before now plus sigma h after, w = 1/2 + sigma (a first-order
// error if charged over the whole window). The elastic force k delta stops falling linearly there, a
// kink whose missed impulse k v_n h^2 (2 sigma - 1)^2 / 8 is charged as an extra overlap, as at touching.
// Not parting within the step: w = 1, nothing extra. Adds to the onset of a contact touching and parting
// within one step. The parting is a prediction: a pair predicted to part before the next evaluation but
// still overlapping there has its charge taken back there (contact_forces.hpp), else it would be charged
// twice (realised e_N 1.3 % low at e_N = 0.5, 5.5 % at 0.015, for touching times in a few per cent of a
// step).
// The initial evaluation (dt = 0) is charged over the first half kick only, [0, h/2]: a pair parting at
// sigma h needs its dashpot over [0, sigma h], w = 2 sigma, and the elastic force's exact impulse
// k v_n sigma^2 h^2 / 2, an extra overlap travel sigma (sigma - 1). Charged over [0, h/2] as at any step
// (w = 1), a contact present at the start and parting at 0.74 of the first step would leave 3.5 % too fast
// (1.3 % too slow at 0.38).
inline Onset parting(const ContactStep& p, Onset on) {
  const bool initial = p.dt <= 0;
  const double travel = p.vn * (initial ? p.first_step : p.dt);   // the overlap lost over the step ahead
  if (!(travel > p.overlap)) return on;
  const double sigma = p.overlap / travel;
  if (initial) return {2 * sigma, travel * sigma * (sigma - 1)};   // onset: nothing at the initial evaluation
  return {on.dashpot_weight + sigma - 0.5, on.extra_overlap + travel * (2 * sigma - 1) * (2 * sigma - 1) / 8};
}

// Clamp release of the non-pulling law: the force f = k delta - c v_n falls to zero and stays clamped
// at zero after, a kink the kicks would miss f' h^2 (2 sigma - 1)^2 / 8 of (the release at sigma
// steps after the last positive sample). With `drop` = -f' h, the force's fall over one step, the
// release is predicted sigma = f / drop steps ahead; the missed impulse is spread over the two steps
// before it, with weights sigma and 2 - sigma that go to zero where a step enters or leaves the
// two-step band, so a slightly wrong prediction never charges it twice or not at all. Returns the
// extra force for this step; the caller has checked 0 < f < 2 drop (release less than two steps ahead).
inline double release_force(double f, double drop) {
  const double sigma = f / drop;
  const double r = sigma <= 1 ? sigma : sigma - 1, weight = sigma <= 1 ? sigma : 2 - sigma;
  return drop * (2 * r - 1) * (2 * r - 1) / 8 * weight;
}

}  // namespace grains
