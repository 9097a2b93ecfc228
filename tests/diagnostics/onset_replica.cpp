// 1D replica of the engine step for a head-on collision (same law headers, same integrator formulas),
// for diagnosing the contact onset (docs/accuracy.md, binary collisions). Build and run:
//   g++ -O2 -std=c++20 -Iengine tests/diagnostics/onset_replica.cpp -o /tmp/onset_replica && /tmp/onset_replica 1
// Flags (sum): 1 the onset lag as the engine makes it up (contact_step.hpp onset_lag: the law evaluated at
// overlap - lag, the pair moved apart by lag at the next drift); 8 the lag from the exact solution
// instead of its Taylor form; 16 the law evaluated at the uncorrected overlap; 2 first-step dashpot decay;
// 4 the velocity predictor fed with the unweighted (smooth) forces. Flags 0: the engine before the lag.
// A second argument e and n_c prints the errors per onset phase.
#include <cstdio>
#include <cmath>
#include <algorithm>
#include <cstdlib>
#include "interactions/linear_contact_law.hpp"
#include "interactions/normal_calibration.hpp"
using namespace grains;
int FL = 0;
struct Out { double e, dur; };
Out run(double e, double nc, double phase) {
  const double h = 1.0 / nc, ms = 0.5;
  auto kc = calibrate_linear(e, 1.0, 0.5);
  const double z = damping_ratio(e), w0 = std::sqrt(kc.k / ms), wd = w0 * std::sqrt(1 - z * z);
  LinearContactLaw<false> law{kc.k, kc.c, 1.0};
  double gap = (std::round(0.05 * nc) + phase) * h;
  double x[2] = {0, 1 + gap}, v[2] = {0.5, -0.5}, vp[2] = {0.5, -0.5}, a[2] = {0, 0}, ap[2] = {0, 0}, as[2] = {0,0}, asp[2] = {0,0};
  double shift_pending = 0; bool touching = false;
  auto force = [&](double dt, double& fsmooth) {
    double ov = 1 - (x[1] - x[0]);
    fsmooth = 0;
    if (ov <= 0) { touching = false; return 0.0; }
    bool first = !touching && dt > 0; touching = true;
    double before = first ? 1 - ((x[1] - dt * v[1]) - (x[0] - dt * v[0])) : 0;
    double vn = vp[1] - vp[0];
    double corr = 0;
    if (first) {
      double growth = ov - before, s = std::clamp(-before / growth, 0.0, 1.0), u0 = -vn, tau = (1 - s) * h, L = (1.5 - s) * h, g = kc.c / ms;
      if (FL & 1) { double e0 = (FL & 8) ? (tau * u0 - u0 / wd * std::exp(-z * w0 * tau) * std::sin(wd * tau)) : kc.c * u0 * tau * tau / (2 * ms);
        shift_pending = e0; if (!(FL & 16)) { ov -= e0; before = ov - growth; } }
      if (FL & 2) corr -= kc.c * u0 * g * L * L / 2 / h;
    }
    double el; bool cl;
    ContactStep p{ov, before, vn, dt, first};
    double f = law.force(p, 1, 1, law.damping(1, 1), 0.5, el, cl) + corr;
    fsmooth = std::max(0.0, kc.k * ov - kc.c * vn);
    return f;
  };
  double fs;
  double f = force(0, fs); a[1] = f; a[0] = -f; as[1] = fs; as[0] = -fs;
  double t = 0, t_touch = -1, t_part = -1, gprev = x[1] - x[0] - 1, tprev = 0;
  while (t_part < 0 && t < 5) {
    for (int i = 0; i < 2; ++i) { v[i] += 0.5 * h * a[i]; x[i] += h * v[i] + (i ? 0.5 : -0.5) * shift_pending;
      const double* A = (FL & 4) ? as : a; const double* AP = (FL & 4) ? asp : ap;
      vp[i] = v[i] + 0.5 * h * (1.75 * A[i] - 0.75 * AP[i]); }
    shift_pending = 0;
    t += h;
    f = force(h, fs);
    for (int i = 0; i < 2; ++i) { ap[i] = a[i]; asp[i] = as[i]; }
    a[1] = f; a[0] = -f; as[1] = fs; as[0] = -fs;
    for (int i = 0; i < 2; ++i) v[i] += 0.5 * h * a[i];
    double g = x[1] - x[0] - 1;
    if (t_touch < 0 && g < 0) t_touch = tprev + (t - tprev) * gprev / (gprev - g);
    if (t_touch >= 0 && gprev < 0 && g >= 0) t_part = tprev + (t - tprev) * -gprev / (g - gprev);
    gprev = g; tprev = t;
  }
  return {v[1] - v[0], t_part - t_touch};
}
int main(int argc, char** argv) {
  FL = atoi(argv[1]);
  if (argc > 2) { double e = atof(argv[2]), nc = atof(argv[3]); auto kc = calibrate_linear(e, 1.0, 0.5);
    auto ex = clamped_collision(damping_ratio(e), std::sqrt(kc.k / 0.5));
    for (int k = 0; k < 24; ++k) { auto o = run(e, nc, k / 24.0); printf("s=%.3f rest %+.2e dur %+.2e\n", k/24.0, o.e / ex.restitution - 1, o.dur / ex.separation_time - 1); }
    return 0; }
  for (double e : {1.0, 0.9, 0.5, 0.3, 0.2, 0.1, 0.05, 0.03, 0.02, 0.01}) {
    auto kc = calibrate_linear(e, 1.0, 0.5);
    auto ex = clamped_collision(damping_ratio(e), std::sqrt(kc.k / 0.5));
    printf("e=%.2f", e);
    for (double nc : {50.0, 100.0, 200.0, 400.0, 800.0}) {
      double we = 0, wd = 0;
      for (int k = 0; k < 48; ++k) { auto o = run(e, nc, k / 48.0);
        we = std::max(we, std::abs(o.e / ex.restitution - 1)); wd = std::max(wd, std::abs(o.dur / ex.separation_time - 1)); }
      printf(" | nc %3.0f rest %.2e dur %.2e", nc, we, wd);
    }
    printf("\n");
  }
}
