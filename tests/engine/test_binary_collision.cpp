// Head-on binary collisions against the exact solution of the clamped damped oscillator, and that
// exact solution against a fine numerical integration.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/simulation.hpp"
#include "interactions/normal_calibration.hpp"
#include "io/scene.hpp"
#include "head_on_scene.hpp"

using namespace grains;

namespace {

struct Outcome { double restitution, duration, momentum_error; };

// Two equal particles (mass 1, diameter 1) approach at relative speed 1; their surfaces touch `phase`
// of a step after a step boundary (phase 0: on the boundary, where rounding decides the sign of the
// first overlap).
std::unique_ptr<Simulation> head_on(int dim, double e, double nc, double phase) {
  const double dt = 1.0 / nc;
  const double gap = (std::round(0.05 * nc) + phase) * dt;   // surfaces touch after gap / 1 time units
  const std::string text = listed_scene(dim, head_on_pair(dim, gap), {e, 1.0, nc});
  return Simulation::create(Scene::from_string(text, "collision-test"));
}

// Runs the collision to its end. The duration runs from touching to parting: both fall in free flight,
// where the gap is linear in time, so linear interpolation of the sampled gap finds them exactly.
Outcome collide(int dim, double e, double nc, double phase) {
  auto sim = head_on(dim, e, nc, phase);
  Outcome o{};
  auto gap_now = [&] {
    auto p = sim->particles();
    return p.position[dim] - p.position[0] - 1.0;
  };
  double t_touch = -1, t_part = -1, g_prev = gap_now(), t_prev = 0;
  while (t_part < 0 && sim->time() < 5.0) {
    sim->step_n(1);
    const double g = gap_now(), t = sim->time();
    if (t_touch < 0 && g < 0) t_touch = t_prev + (t - t_prev) * g_prev / (g_prev - g);
    if (t_touch >= 0 && g_prev < 0 && g >= 0) t_part = t_prev + (t - t_prev) * -g_prev / (g - g_prev);
    g_prev = g, t_prev = t;
  }
  REQUIRE(t_part > 0);
  auto p = sim->particles();
  const double v0 = p.velocity[0], v1 = p.velocity[dim];
  o.restitution = (v1 - v0) / 1.0;
  o.duration = t_part - t_touch;
  o.momentum_error = std::abs(v0 + v1);
  return o;
}

// Onset phases: 0 (on a step boundary), 1e-9 and 1 - 1e-9 (rounding-level neighbours), and a grid.
std::vector<double> onset_phases() {
  std::vector<double> ph = {0.0, 1e-9, 1 - 1e-9};
  for (int k = 1; k < 24; ++k) ph.push_back(k / 24.0);
  return ph;
}

}  // namespace

// Issue 2: at n_c = 50 the realised restitution and the duration (touching to parting) are within
// 1e-3 of the exact clamped values for every e and onset phase. Without the onset lag correction
// (contact_step.hpp) the duration's error reached 2.7e-3 at e = 0.01. Each e has its own bounds, about
// 2-3 times the worst errors measured (docs/accuracy.md table; 2D and 3D the same), never above that 1e-3 goal.
TEST_CASE("binary collision realises the exact clamped restitution at n_c = 50", "[contact][analytic]") {
  struct Case { double e, restitution_bound, duration_bound; };
  const Case cases[] = {{1.0, 1.5e-5, 5e-4}, {0.9, 1e-4, 5e-4},   {0.7, 3e-4, 4e-4},  {0.5, 5e-4, 3e-4},
                        {0.3, 8e-4, 2e-4},   {0.1, 1e-3, 3e-4},   {0.05, 1e-3, 6e-4}, {0.03, 1e-3, 6e-4},
                        {0.02, 1e-3, 8e-4},  {0.01, 1e-3, 8e-4}};
  for (int dim : {2, 3})
    for (const auto& [e, restitution_bound, duration_bound] : cases) {
      const auto kc = calibrate_linear(e, 1.0, 0.5);
      const auto exact = clamped_collision(damping_ratio(e), std::sqrt(kc.k / 0.5));
      double worst = 0, worst_duration = 0;
      for (double phase : onset_phases()) {
        auto o = collide(dim, e, 50, phase);
        worst = std::max(worst, std::abs(o.restitution / exact.restitution - 1));
        worst_duration = std::max(worst_duration, std::abs(o.duration / exact.separation_time - 1));
        CHECK(o.momentum_error < 1e-14);
      }
      WARN(fmt::format("D = {}, e = {}: worst relative error over {} onset phases at n_c = 50: restitution {:.2e}, "
                       "duration {:.2e}", dim, e, onset_phases().size(), worst, worst_duration));
      CHECK(worst < restitution_bound);
      CHECK(worst_duration < duration_bound);
    }
}

// The contact's first step is recognised from a per-pair record of the previous evaluation, carried
// across neighbour-list rebuilds and saved with the state: a list rebuilt at every step while another
// pair enters it (which moves the colliding pair's place in the list), or a save/restore in the middle
// of the contact, must give the same collision bit for bit.
TEST_CASE("binary collision: the per-pair contact record survives list rebuilds and save/restore", "[contact]") {
  for (int dim : {2, 3})
    for (double phase : {0.0, 0.3}) {
      const double nc = 50, dt = 1 / nc;
      // Particles 1 and 2 collide head-on (touching after 2 + phase steps); far away, 3 runs into 0,
      // so that the pair (0, 3) enters the list (under row 0, before the colliding pair's row) during
      // that collision.
      ListedParticles parts = head_on_pair(dim, (2 + phase) * dt);
      std::vector<double> at_rest(dim, 0.0), spectator(dim, 0.0), running(dim, 0.0);
      spectator[1] = 10;
      parts.positions.insert(parts.positions.begin(), spectator);
      parts.velocities.insert(parts.velocities.begin(), at_rest);
      spectator[0] = 1.2, running[0] = -1;
      parts.positions.push_back(spectator), parts.velocities.push_back(running);
      parts.diameters = {1, 1, 1, 1}, parts.masses = {1, 1, 1, 1};
      auto run = [&](const std::string& extra) {
        return Simulation::create(Scene::from_string(listed_scene(dim, parts, {0.3, 1.0, nc}) + extra, "record"));
      };
      auto reference = run("");
      reference->step_n(long(4 * nc));
      const auto v_ref = reference->particles().velocity;
      // Rebuilds: a skin of 1e-4 is used up by 2 steps of a particle moving at 0.5 with dt = 0.02.
      auto rebuilt = run("[neighbours]\nskin = 1e-4\n");
      rebuilt->step_n(long(4 * nc));
      CHECK(rebuilt->particles().velocity == v_ref);
      // Save after the contact's first step (its onset lag is still to be made up in the next step)
      // and after its second, restore into a fresh run.
      for (long at : {3L, 4L}) {
        auto first = run("");
        first->step_n(at);
        REQUIRE(first->get("contacts") == 1.0);
        const auto state = first->save_state();
        auto second = run("");
        second->restore_state(state);
        second->step_n(long(4 * nc) - at);
        CHECK(second->particles().velocity == v_ref);
      }
    }
}

// The reference itself: clamped_collision() against a fourth-order Runge-Kutta integration of the
// clamped oscillator delta'' = -max(0, w0^2 delta + 2 zeta w0 delta') with 1e5 steps per contact.
TEST_CASE("the exact clamped collision agrees with a fine numerical integration", "[contact][analytic]") {
  for (double e : {0.95, 0.7, 0.5, 0.3, 0.1, 0.03, 0.01}) {
    const double zeta = damping_ratio(e), w0 = 1.0;
    const auto exact = clamped_collision(zeta, w0);
    const double h = exact.separation_time / 1e5;
    auto accel = [&](double x, double v) { return -std::max(0.0, w0 * w0 * x + 2 * zeta * w0 * v); };
    double x = 0, v = 1, t = 0, t_release = -1, t_part = -1;
    while (t_part < 0) {
      const double f_before = accel(x, v);
      const double k1x = v, k1v = accel(x, v);
      const double k2x = v + 0.5 * h * k1v, k2v = accel(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
      const double k3x = v + 0.5 * h * k2v, k3v = accel(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
      const double k4x = v + h * k3v, k4v = accel(x + h * k3x, v + h * k3v);
      const double x_new = x + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x), v_new = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
      const double f_after = accel(x_new, v_new);
      // Release: the (negative) acceleration reaches zero; linear interpolation, good to h^2.
      if (t_release < 0 && f_before < 0 && f_after == 0) {
        const double unclamped = -(w0 * w0 * x_new + 2 * zeta * w0 * v_new);
        t_release = t + h * f_before / (f_before - unclamped);
      }
      if (x_new < 0) t_part = t + h * x / (x - x_new);   // free flight by then: linear
      x = x_new, v = v_new, t += h;
    }
    const double de = std::abs(-v / exact.restitution - 1), dr = std::abs(t_release / exact.contact_time - 1),
                 dp = std::abs(t_part / exact.separation_time - 1);
    INFO(fmt::format("e = {}: relative deviation of the restitution {:.1e}, release time {:.1e}, parting time {:.1e}",
                     e, de, dr, dp));
    CHECK(de < 1e-10);
    CHECK(dr < 1e-10);
    CHECK(dp < 1e-10);
  }
}

// The duration's error (touching to parting) is second order in dt, also where it is largest (low e):
// at e = 0.01 the observed order approaches 2 from below (1.73, 1.84, 1.91 from n_c = 50 to 400), so
// every order must exceed 1.7 and the last 1.85 (a first-order error would give 1).
TEST_CASE("binary collision: the contact duration converges at second order", "[contact][convergence]") {
  for (double e : {0.5, 0.1, 0.01}) {
    const auto kc = calibrate_linear(e, 1.0, 0.5);
    const auto exact = clamped_collision(damping_ratio(e), std::sqrt(kc.k / 0.5));
    std::vector<double> worst;
    for (double nc : {50.0, 100.0, 200.0, 400.0}) {
      double w = 0;
      for (double phase : onset_phases()) w = std::max(w, std::abs(collide(3, e, nc, phase).duration / exact.separation_time - 1));
      worst.push_back(w);
    }
    std::vector<double> order;
    for (std::size_t k = 1; k < worst.size(); ++k) order.push_back(std::log2(worst[k - 1] / worst[k]));
    WARN(fmt::format("e = {}: worst relative error of the duration at n_c = 50, 100, 200, 400: {:.2e}; "
                     "observed orders {:.2f}", e, fmt::join(worst, " "), fmt::join(order, " ")));
    for (double o : order) CHECK(o >= 1.7);
    CHECK(order.back() >= 1.85);
  }
}

namespace {
// The clamped oscillator from overlap x0 > 0 and overlap rate u0 (negative: separating), natural frequency w0,
// damping ratio zeta < 1, before the release: x(t) = exp(-zeta w0 t) (A cos w_d t + B sin w_d t). The release
// is the first zero of the acceleration -(w0^2 x + 2 zeta w0 x'); the pair coasts at x' from then on.
struct Release { double time, rate; };
Release exact_release(double x0, double u0, double zeta, double w0) {
  const double wd = w0 * std::sqrt(1 - zeta * zeta), A = x0, B = (u0 + zeta * w0 * x0) / wd;
  auto state = [&](double t) {
    const double decay = std::exp(-zeta * w0 * t), c = std::cos(wd * t), s = std::sin(wd * t);
    const double x = decay * (A * c + B * s);
    const double u = decay * ((B * wd - zeta * w0 * A) * c - (A * wd + zeta * w0 * B) * s);
    return std::pair{x, u};
  };
  auto accel = [&](double t) {
    const auto [x, u] = state(t);
    return -(w0 * w0 * x + 2 * zeta * w0 * u);
  };
  double lo = 0, hi = 1e-3;   // the acceleration is negative (repulsive) at the start
  while (accel(hi) < 0) lo = hi, hi *= 2;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (accel(mid) < 0 ? lo : hi) = mid;
  }
  return {hi, state(hi).second};
}
}  // namespace

// A contact present at the start and separating: velocity Verlet charges the initial force evaluation over
// the first half kick only, [0, h/2], so a clamp release within the first step needs its own correction there
// (linear_contact_law.hpp). Two unit-mass disks overlapping by x0 and separating at relative speed 1, e = 0.5,
// n_c = 50: the final relative speed against the closed-form oscillator solution, for releases at shares of
// the first steps. Without that correction a release within the first step leaves 2e-4 to 5.2e-4 too fast (0.9 and
// 0.5 of the step); with it below 1.3e-5. A release after the first step keeps velocity Verlet's second-order term of
// a half first kick, f' h^2 / 8 (the kicks after it are midpoint windows, the release's correction assumes
// so): 3.8e-4 to 4.5e-4 measured, the linear estimate 5.6e-4.
TEST_CASE("a contact present at the start and released within the first steps leaves at the exact speed",
          "[contact][analytic]") {
  const double e = 0.5, nc = 50, dt = 1 / nc, zeta = damping_ratio(e);
  const double w0 = std::sqrt(calibrate_linear(e, 1.0, 0.5).k / 0.5);
  for (int dim : {2, 3}) {
    std::string table;
    for (double share : {0.2, 0.38, 0.5, 0.74, 0.9, 1.3, 1.7, 3.0, 6.0}) {
      // The overlap whose exact release falls at share * dt (later for a deeper start).
      double lo = 2 * zeta / w0, hi = 1.0;
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        (exact_release(mid, -1.0, zeta, w0).time < share * dt ? lo : hi) = mid;
      }
      const double x0 = 0.5 * (lo + hi), exact = -exact_release(x0, -1.0, zeta, w0).rate;
      ListedParticles parts = head_on_pair(dim, -x0);
      parts.velocities[0][0] = -0.5, parts.velocities[1][0] = 0.5;
      auto sim = Simulation::create(Scene::from_string(listed_scene(dim, parts, {e, 1.0, nc}), "release"));
      sim->step_n(long(share) + 3);
      const auto p = sim->particles();
      const double error = (p.velocity[dim] - p.velocity[0]) / exact - 1;
      table += fmt::format(" {}:{:.2e}", share, error);
      INFO(dim << "D, release at " << share << " steps: relative error of the final speed " << error);
      CHECK(std::abs(error) < (share < 1 ? 3e-5 : 6e-4));
    }
    WARN("D = " << dim << ": relative error of the final speed by release (in steps):" << table);
  }
}
