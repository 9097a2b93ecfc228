// Linear spring-dashpot calibration from restitution e and contact duration t_c (physics.md section 2).
#pragma once
#include <cmath>
#include <numbers>

namespace grains {

struct SpringDashpot { double k, c; };

// zeta = -ln e / sqrt(pi^2 + ln^2 e); k = m* (pi^2 + ln^2 e) / t_c^2; c = -2 m* ln e / t_c.
inline SpringDashpot calibrate_linear(double e, double t_c, double reduced_mass) {
  const double le = std::log(e), pi2 = std::numbers::pi * std::numbers::pi;
  // + 0.0: an elastic contact (ln e = 0) gets c = 0, not -0, which the scene's echo printed as "c_n = -0"
  return {reduced_mass * (pi2 + le * le) / (t_c * t_c), -2.0 * reduced_mass * le / t_c + 0.0};
}

inline double damping_ratio(double e) {
  const double le = std::log(e);
  return -le / std::sqrt(std::numbers::pi * std::numbers::pi + le * le) + 0.0;   // + 0.0: e = 1 gives 0, not -0
}

// Exact head-on collision of the clamped (non-pulling) damped oscillator, zeta < 1, natural
// frequency w0: the force k delta - c v_n reaches zero at w_d t_r = pi - atan2(2 zeta sqrt(1 - zeta^2), 1 - 2 zeta^2)
// (contact_time, counted from touching); the pair then coasts out of the overlap k delta_r / c = v_r,
// so the surfaces part c / k = 2 zeta / w0 later (separation_time).
struct ClampedCollision { double restitution, contact_time, separation_time; };
inline ClampedCollision clamped_collision(double zeta, double w0) {
  const double s = std::sqrt(1 - zeta * zeta), wd = w0 * s;
  const double tr = (std::numbers::pi - std::atan2(2 * zeta * s, 1 - 2 * zeta * zeta)) / wd;
  const double v = std::exp(-zeta * w0 * tr) * (std::cos(wd * tr) - zeta / s * std::sin(wd * tr));
  return {-v, tr, tr + 2 * zeta / w0};
}

// "exact" calibration: the damping ratio whose clamped collision realises e, and the k that keeps
// that collision's duration t_c (bisection; the realised e falls monotonically with zeta).
inline SpringDashpot calibrate_exact(double e, double t_c, double reduced_mass) {
  if (e >= 1.0) return calibrate_linear(1.0, t_c, reduced_mass);
  double lo = 0, hi = 1 - 1e-12;
  for (int it = 0; it < 200; ++it) {
    double mid = 0.5 * (lo + hi);
    (clamped_collision(mid, 1.0).restitution > e ? lo : hi) = mid;
  }
  const double zeta = 0.5 * (lo + hi);
  const double w0 = clamped_collision(zeta, 1.0).contact_time / t_c;   // duration scales as 1/w0
  const double k = reduced_mass * w0 * w0;
  return {k, 2 * zeta * std::sqrt(reduced_mass * k)};
}

}  // namespace grains
