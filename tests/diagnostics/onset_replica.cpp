// 1D replica of the engine step for a head-on collision (same law headers, same integrator formulas), with
// toggles for diagnosing the contact onset (README, binary collisions). Build and run:
//   g++ -O2 -std=c++20 -Iengine tests/diagnostics/onset_replica.cpp -o /tmp/onset_replica && /tmp/onset_replica 0
// Flags (sum): 1 position dipole +d/-d on the first two steps, 256 remove it from the next three predicted
// dashpot velocities, 64 compensate (c/m*) e0; 4/8 exact dashpot velocity at steps 2/3 (oracle); 2/16
// first-step dashpot decay (Taylor/exponential); 128 dipole from the exact offset. A second argument
// e and n_c prints the errors per onset phase.
#include <cstdio>
#include <cmath>
#include <algorithm>
#include <cstdlib>
#include "interactions/linear_contact_law.hpp"
#include "interactions/normal_calibration.hpp"
using namespace grains;
int FL = 0; double DD = 0;  // 1 dipole, 2 decay, 4 oracle vp step2, 8 oracle vp step3
struct Out { double e, dur; };
Out run(double e, double nc, double phase) {
  const double h = 1.0 / nc;
  auto kc = calibrate_linear(e, 1.0, 0.5);
  const double ms = 0.5, z = damping_ratio(e), w0 = std::sqrt(kc.k / ms), sq = std::sqrt(1 - z * z), wd = w0 * sq;
  LinearContactLaw<false> law{kc.k, kc.c, 1.0};
  double gap = (std::round(0.05 * nc) + phase) * h;
  double x[2] = {0, 1 + gap}, v[2] = {0.5, -0.5}, vp[2] = {0.5, -0.5}, a[2] = {0, 0}, ap[2] = {0, 0};
  int nstep = -1; double pending = 0, t = 0, ttouch_exact = gap;  // exact touching time
  auto uex = [&](double tt) { double q = tt - ttouch_exact; return std::exp(-z * w0 * q) * (std::cos(wd * q) - z / sq * std::sin(wd * q)); };
  auto force = [&](double dt) {
    double ov = 1 - (x[1] - x[0]);
    if (ov <= 0) { nstep = -1; double f = pending; pending = 0; return -f; }
    ++nstep;
    bool first = nstep == 0;
    double before = first ? 1 - ((x[1] - dt * v[1]) - (x[0] - dt * v[0])) : 0;
    double vn = vp[1] - vp[0];
    if ((FL & 4) && nstep == 1) vn = -uex(t);
    if (FL & 256) { double hm = h * DD / ms; if (nstep == 1) vn -= 15.0 / 8 * hm; if (nstep == 2) vn += 10.0 / 8 * hm; if (nstep == 3) vn -= 3.0 / 8 * hm; }
    if ((FL & 8) && nstep == 2) vn = -uex(t);
    double el; bool cl;
    ContactStep p{ov, before, vn, dt, first};
    double f = law.force(p, 1, 1, 0.5, el, cl);
    double extra = -pending; pending = 0;
    if (first && dt > 0) {
      double growth = ov - before, s = std::clamp(-before / growth, 0.0, 1.0);
      double u0 = -vn, L = (1.5 - s) * h, g = kc.c / ms;
      if (FL & 1) { double d = kc.c * u0 * (1 - s) * (1 - s) / 2; extra += d; pending = d; DD = d; }
      if (FL & 128) { double q = (1 - s) * h; double de = (1 - s) * h * u0 - u0 / wd * std::exp(-z * w0 * q) * std::sin(wd * q);
        double d = de * ms / (h * h); extra += d; pending = d; }
      if (FL & 32) f += kc.c * (kc.c * u0 * (1 - s) * (1 - s) * h * h / 2 / ms) / h;
      if (FL & 64) f -= kc.c * (kc.c * u0 * (1 - s) * (1 - s) * h * h / 2 / ms) / h;
      if (FL & 2) f -= kc.c * u0 * g * L * L / 2 / h;
      if (FL & 16) f += kc.c * u0 * ((1 - std::exp(-g * L)) / g - L) / h;
    }
    return f + extra;
  };
  double f = force(0); a[1] = f; a[0] = -f;
  double t_touch = -1, t_part = -1, gprev = x[1] - x[0] - 1, tprev = 0;
  while (t_part < 0 && t < 5) {
    for (int i = 0; i < 2; ++i) { v[i] += 0.5 * h * a[i]; x[i] += h * v[i]; vp[i] = v[i] + 0.5 * h * (1.75 * a[i] - 0.75 * ap[i]); }
    t += h;
    f = force(h);
    for (int i = 0; i < 2; ++i) ap[i] = a[i];
    a[1] = f; a[0] = -f;
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
  double ncs[3] = {50, 100, 200};
  for (double e : {1.0, 0.5, 0.1, 0.03, 0.01}) {
    auto kc = calibrate_linear(e, 1.0, 0.5);
    auto ex = clamped_collision(damping_ratio(e), std::sqrt(kc.k / 0.5));
    printf("e=%.2f", e);
    for (double nc : ncs) {
      double we = 0, wd = 0;
      for (int k = 0; k < 48; ++k) {
        auto o = run(e, nc, k / 48.0);
        we = std::max(we, std::abs(o.e / ex.restitution - 1));
        wd = std::max(wd, std::abs(o.dur / ex.separation_time - 1));
      }
      printf(" | nc %3.0f rest %.2e dur %.2e", nc, we, wd);
    }
    printf("\n");
  }
}
