// Stability of the integrator's dashpots (core/integrator.hpp) for a grain held by many damped contacts.
//
// The dashpots read a predicted velocity, v(t+h) ~ v(t+h/2) + h/2 (7/4 a_n - 3/4 a_{n-1}), which keeps a
// collision's restitution second-order accurate but is explicit: a mode of (reduced) mass m held by
// springs of total stiffness K and dashpots of total coefficient C (m x'' = -K x - C v) is stable only for
// w h <= limit(zeta), w = sqrt(K / m), zeta = C / (2 sqrt(K m)): 2 without damping, 0.31 at zeta = 0.9,
// falling about as 0.28 / zeta for zeta > 1 (C h / m below 0.57, where the half-step velocity allows 2). One
// contact between two grains is far inside it; a light grain pressed by a dozen strongly damped ones
// (a dense self-gravitating aggregate at zeta = 0.9 and 30 steps per contact) is not, and such packings
// heat up instead of settling. The limit is found from the scheme's own one-step matrix.
#pragma once
#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace grains {

// Largest modulus of the eigenvalues of one step of the scheme for x'' = -w^2 x - 2 zeta w v, time step 1,
// state (x, v, a_n, a_{n-1}); above 1 the step amplifies some motion.
inline double predicted_dashpot_growth(double w_h, double zeta) {
  const double k = w_h * w_h, c = 2 * zeta * w_h;
  Eigen::Matrix4d step;
  for (int j = 0; j < 4; ++j) {
    Eigen::Vector4d s = Eigen::Vector4d::Unit(j);
    const double x = s[0], v = s[1], a = s[2], a_prev = s[3];
    const double v_half = v + 0.5 * a, x_next = x + v_half;
    const double v_predicted = v_half + 0.5 * (1.75 * a - 0.75 * a_prev);
    const double a_next = -k * x_next - c * v_predicted;
    step.col(j) << x_next, v_half + 0.5 * a_next, a_next, a;
  }
  return step.eigenvalues().cwiseAbs().maxCoeff();
}

// The largest w h for which every smaller one is stable (bisection; the unstable range starts there).
inline double predicted_dashpot_limit(double zeta) {
  double lo = 0, hi = 2.0;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (predicted_dashpot_growth(mid, zeta) <= 1 + 1e-12 ? lo : hi) = mid;
  }
  return lo;
}

}  // namespace grains
