// The contact law at its extremes: restitution 1e-4 and 1, stiffness over six decades, a dense
// periodic system whose energy may never grow, size ratio 10, the time-step rule's boundary, a
// blow-up that must stop with a clear error (also when the particles leave for 1e308), and friction: momentum, angular momentum and a
// bit-for-bit save/restore in the middle of a sliding contact.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "core/simulation.hpp"
#include "interactions/normal_calibration.hpp"
#include "io/scene.hpp"
#include "head_on_scene.hpp"
#include "warnings_of.hpp"

using namespace grains;
using Catch::Contains;
using Catch::StartsWith;

namespace {

std::unique_ptr<Simulation> make(const std::string& text) { return Simulation::create(Scene::from_string(text, "extremes")); }

// Head-on collision of two spheres (diameters d1, d2, masses from unit density unless given) at
// closing speed `speed`; returns the realised restitution.
struct HeadOn {
  double d1 = 1, d2 = 1, m1 = 0, m2 = 0;   // 0: mass from density 1
  double speed = 1.0;
  double e = 0.5, tc = 1.0, nc = 50, phase = 0.37;
  std::string calibration = "global";
};

double realised_restitution(const HeadOn& h, bool& finite) {
  const double dt = h.tc / h.nc;
  const double gap = h.speed * (3 + h.phase) * dt;
  ListedParticles parts{{{0, 0, 0}, {0.5 * (h.d1 + h.d2) + gap, 0, 0}}, {{h.speed, 0, 0}, {0, 0, 0}}, {h.d1, h.d2}, {}};
  if (h.m1 > 0) parts.masses = {h.m1, h.m2};
  auto sim = make(listed_scene(3, parts, {h.e, h.tc, h.nc, h.calibration}));
  finite = true;
  const long steps = long(std::ceil(gap / h.speed / dt)) + long(4 * h.nc);
  for (long k = 0; k < steps; ++k) {
    sim->step_n(1);
    finite &= std::isfinite(sim->get("kinetic_energy")) && std::isfinite(sim->get("elastic_energy"));
  }
  REQUIRE(sim->get("contacts") == 0.0);
  const auto p = sim->particles();
  REQUIRE(p.position[3] > p.position[0]);
  return (p.velocity[3] - p.velocity[0]) / h.speed;
}

double clamped_for(double e, double tc, double mstar_law, double mstar_pair) {
  const auto kc = calibrate_linear(e, tc, mstar_law);
  return clamped_collision(kc.c / (2 * std::sqrt(mstar_pair * kc.k)), std::sqrt(kc.k / mstar_pair)).restitution;
}

std::string dense_periodic(double e, double tc, const std::string& time = "steps_per_contact = 50") {
  return fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "random"
count = 200
size_distribution = "uniform"
diameter_min = 0.8
diameter_max = 1.0
solid_fraction = 0.3
velocity = "gaussian"
kinetic_energy = 1.0
seed = 7
[contact]
restitution = {}
duration = {}
overlap_limit = 0.1
[time]
{}
[run]
threads = 1
)", e, tc, time);
}

double total_energy(const Simulation& s) { return s.get("kinetic_energy") + s.get("elastic_energy"); }

// The warnings of the time-step rules alone: at t_c = 1 (and dt = 5 t_c) this gas's grains also close more than
// the clamp depth per step, which the initial-speed check warns about besides.
std::vector<std::string> step_rule_warnings(const Simulation& s) {
  std::vector<std::string> w;
  for (const auto& m : s.warnings())
    if (m.find("pass through each other unseen") == m.npos) w.push_back(m);
  return w;
}

}  // namespace

TEST_CASE("extremes: restitution 1e-4 and 1 realise the exact clamped values", "[extremes]") {
  // The restitution error is second order, |error| <= C (w0 dt)^2 with w0 = sqrt(k / m*) (for
  // e = 1e-4, w0 = 9.7 / t_c: ten steps per realised contact at n_c = 50). Over e = 0.9 .. 1e-4 and
  // every onset/release phase C stays below 0.13 (test_collision_convergence); the bound takes 0.25.
  for (double e : {1e-4, 1.0})
    for (double nc : {50.0, 100.0}) {
      const double exact = clamped_for(e, 1.0, 0.5, 0.5);
      const auto kc = calibrate_linear(e, 1.0, 0.5);
      const double w0dt = std::sqrt(kc.k / 0.5) / nc;
      double worst = 0;
      for (double phase : {0.05, 0.37, 0.81}) {
        HeadOn h;
        h.m1 = h.m2 = 1.0, h.e = e, h.phase = phase, h.speed = 0.2, h.nc = nc;
        bool finite;
        worst = std::max(worst, std::abs(realised_restitution(h, finite) - exact));
        CHECK(finite);
      }
      INFO("e = " << e << ", n_c = " << nc << ": exact clamped restitution " << exact << ", worst error " << worst
                  << ", bound " << 0.25 * w0dt * w0dt);
      CHECK(worst < 0.25 * w0dt * w0dt);
      // Without a dashpot the error falls much faster than the bound above allows for (measured 5.3e-6 at
      // n_c = 50 and 3.3e-7 at 100, fourth order): bounded near it, so that a slip in the undamped law shows.
      if (e == 1.0) CHECK(worst < 2e-5 * std::pow(50 / nc, 4));
    }
  // e = 1e-4 is far below what the clamped law can realise: the clamp floors it near exp(-2).
  CHECK(clamped_for(1e-4, 1.0, 0.5, 0.5) > std::exp(-2.0));
}

TEST_CASE("extremes: stiffness over six decades at fixed masses gives the same finite collision", "[extremes]") {
  // m* = 1/2 (unit density, unit diameter -> m = pi/6; use explicit unit masses instead).
  const double mstar = 0.5, e = 0.3, ln = std::log(e);
  const double exact = clamped_for(e, 1.0, mstar, mstar);   // independent of k and t_c
  for (int decade = 0; decade <= 6; ++decade) {
    const double k = std::pow(10.0, decade);
    const double tc = std::sqrt(mstar * (std::numbers::pi * std::numbers::pi + ln * ln) / k);
    REQUIRE(calibrate_linear(e, tc, mstar).k == Approx(k).epsilon(1e-12));
    HeadOn h;
    h.m1 = h.m2 = 1.0, h.e = e, h.tc = tc, h.speed = 0.1;   // overlap <= speed / w0 = 0.07 R at k = 1
    bool finite;
    const double r = realised_restitution(h, finite);
    INFO("k = " << k << " (t_c = " << tc << "): realised " << r << ", exact " << exact);
    CHECK(finite);
    CHECK(std::abs(r - exact) < 1e-3);
  }
}

TEST_CASE("extremes: K + elastic energy never grows in a dense periodic system, six stiffness decades", "[extremes]") {
  // 200 polydisperse spheres at solid fraction 0.3 (random insertion in the particles' order jams above it)
  // with Gaussian velocities: many simultaneous contacts, from heavily clamped soft ones (t_c = 1)
  // to stiff ones (t_c = 1e-3). The dashpot only removes energy and the clamped spring stores it
  // exactly (elastic_energy is the clamped potential). What velocity Verlet conserves for a spring
  // of frequency w is not K + U but a modified energy that differs from it by (w dt / 2)^2 U; so
  // while a contact is compressed and its velocity nearly zero (no dissipation), the sampled K + U can
  // rise by up to (w dt / 2)^2 of the elastic energy. The bound per step: that, with the stiffest
  // contact's w (global calibration: the lightest pair), plus round-off of the sums (1e-13 E).
  for (double e : {1e-4, 0.5, 0.9})
    for (double tc : {1.0, 0.1, 0.01, 0.001}) {   // k ~ 1/t_c^2: six decades
      auto sim = make(dense_periodic(e, tc));
      const double w_max = std::sqrt(std::numbers::pi * std::numbers::pi + std::log(e) * std::log(e)) / tc;
      const double verlet = std::pow(0.5 * w_max * sim->dt(), 2);
      const double start = total_energy(*sim);
      double previous = start, previous_elastic = sim->get("elastic_energy"), worst = 0, largest_rise = 0, contacts = 0;
      long steps_with_rise = 0;
      // At least 400 steps, and 0.3 time units so that the stiff cases see many collisions too.
      const long steps = std::max(400L, long(std::ceil(0.3 / sim->dt())));
      for (long k = 0; k < steps; ++k) {
        sim->step_n(1);
        const double now = total_energy(*sim), elastic = sim->get("elastic_energy");
        REQUIRE(std::isfinite(now));
        const double allowed = 1e-13 * previous + verlet * std::max(elastic, previous_elastic);
        worst = std::max(worst, (now - previous) / allowed);
        largest_rise = std::max(largest_rise, (now - previous) / previous);
        steps_with_rise += now > previous * (1 + 1e-13);
        contacts = std::max(contacts, sim->get("contacts"));
        previous = now, previous_elastic = elastic;
      }
      WARN(fmt::format("e = {}, t_c = {}: {} steps, {} contacts at most, {} clamped contact-steps, energy {:.4g} -> {:.4g}; "
                       "{} steps rose beyond round-off, largest relative rise {:.3e}, worst rise / allowed {:.3g}",
                       e, tc, steps, contacts, sim->get("clamped_contacts_total"), start, previous, steps_with_rise,
                       largest_rise, worst));
      CHECK(contacts >= 5);
      CHECK(previous < start);
      CHECK(worst <= 1.0);
      CHECK(steps_with_rise <= steps / 1000);   // rare: only near the turning point of a slow contact
    }
}

TEST_CASE("extremes: size ratio 10 head-on realises the per-pair clamped restitution", "[extremes]") {
  for (double e : {0.9, 0.5, 0.1}) {
    HeadOn h;
    h.d1 = 0.1, h.d2 = 1.0, h.e = e, h.calibration = "per-pair", h.speed = 0.05;
    const double m1 = std::numbers::pi / 6 * 1e-3, m2 = std::numbers::pi / 6;
    const double mstar = m1 * m2 / (m1 + m2);
    const double exact = clamped_for(e, 1.0, mstar, mstar);
    double worst = 0;
    for (double phase : {0.1, 0.6}) {
      h.phase = phase;
      bool finite;
      worst = std::max(worst, std::abs(realised_restitution(h, finite) - exact));
      CHECK(finite);
    }
    INFO("e = " << e << ", diameters 0.1 and 1 (m* = " << mstar << "): exact " << exact << ", worst error " << worst);
    CHECK(worst < 1e-3);
  }
}

TEST_CASE("extremes: the time-step rule warns exactly past t_c / 20 and names both numbers", "[extremes]") {
  for (double tc : {1.0, 0.38, 0.0123, 3.7e-5}) {
    const std::string at_rule = fmt::format("dt = {}", tc / 20);   // shortest exact decimal of t_c / 20
    auto ok = make(dense_periodic(0.5, tc, at_rule));
    INFO("t_c = " << tc);
    CHECK(step_rule_warnings(*ok).empty());
    auto by_count = make(dense_periodic(0.5, tc, "steps_per_contact = 20"));
    CHECK(step_rule_warnings(*by_count).empty());
    auto past = make(dense_periodic(0.5, tc, fmt::format("dt = {}", tc / 19)));
    REQUIRE(step_rule_warnings(*past).size() == 1);
    CHECK_THAT(step_rule_warnings(*past)[0], Contains(fmt::format("{:.6g}", tc / 19)) && Contains(fmt::format("{:.6g}", tc / 20)));
    auto past_count = make(dense_periodic(0.5, tc, "steps_per_contact = 19"));
    REQUIRE(step_rule_warnings(*past_count).size() == 1);
    CHECK_THAT(step_rule_warnings(*past_count)[0], Contains(fmt::format("{:.6g}", tc / 19)) && Contains(fmt::format("{:.6g}", tc / 20)));
  }
}

TEST_CASE("extremes: a huge time step blows up into a SimulationError naming the particle and the step", "[extremes]") {
  // dt = 5 t_c with strong damping: the explicit dashpot amplifies each collision (c dt / m* >> 2),
  // the velocities grow geometrically until they overflow.
  auto sim = make(dense_periodic(0.01, 0.01, "dt = 0.05"));
  REQUIRE(step_rule_warnings(*sim).size() == 2);   // past t_c / 20, and past the damped-packing limit
  CHECK_THAT(step_rule_warnings(*sim)[1], Contains("damped contacts"));
  CHECK_THAT(sim->warnings()[2], Contains("pass through each other unseen"));   // and grains closing past the clamp
  try {
    sim->step_n(100000);
    FAIL("no SimulationError after 100000 steps at dt = 5 t_c; kinetic energy " << sim->get("kinetic_energy"));
  } catch (const SimulationError& err) {
    const std::string what = err.what();
    INFO(what);
    // Non-finite, or (first) a particle flung a million cell lengths between builds.
    CHECK_THAT(what, Contains("particle") && Contains("step") &&
                         (Contains("non-finite") || Contains("cell lengths from the periodic cell")));
    CHECK_THAT(what, Contains("the checks warned") && Contains(sim->warnings()[0]));   // the broken rule named
    CHECK(sim->step_count() < 100000);
  }
}

TEST_CASE("extremes: particles flung to 1e308 in an open box stop with the non-finite error, not a crash", "[extremes]") {
  // dt = 1e308: the first drift puts the pair at +-5e307, where the open box's extent overflows to inf;
  // the neighbour grid must still take them (one cell), and the next drift's inf must be reported.
  auto sim = make(listed_scene(3, head_on_pair(3, 0.2), {0.5, 0.1, 50}) + "dt = 1e308\n");
  CHECK_THROWS_WITH(sim->step_n(20), Contains("non-finite value") && Contains("particle"));
}

namespace {

// Two spheres, the second sliding obliquely into the first with spin, friction on. 3D, open box.
std::string oblique(double mu, int threads = 1, double skin = 0.05) {
  return fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "list"
positions = [[0.1, -0.2, 0.3], [1.35, 0.45, 0.0]]
diameters = [1.0, 0.8]
masses = [1.0, 0.6]
velocity = "list"
velocities = [[0.3, 0.1, -0.05], [-0.9, -0.2, 0.1]]
angular_velocities = [[0.0, 0.5, -1.0], [2.0, 0.0, 0.3]]
[box]
periodic = false
[contact]
restitution = 0.6
duration = 0.1
[friction]
coefficient = {}
damping_ratio = 0.5
[neighbours]
skin = {}
[time]
steps_per_contact = 50
[run]
threads = {}
)", mu, skin, threads);
}

struct Totals { double p[3], L[3]; };
Totals totals(const Simulation& s) {
  Totals t{};
  for (int a = 0; a < 3; ++a) {
    t.p[a] = s.get(fmt::format("momentum_{}", "xyz"[a]));
    t.L[a] = s.get(fmt::format("angular_momentum_{}", "xyz"[a]));
  }
  return t;
}

}  // namespace

TEST_CASE("extremes: an oblique frictional collision conserves linear and angular momentum", "[extremes][friction]") {
  for (double mu : {0.1, 0.5, 2.0}) {   // sliding throughout, mixed, mostly sticking
    auto sim = make(oblique(mu));
    const Totals t0 = totals(*sim);
    // Scales: |p| and |L| from the particles' own magnitudes, so that a zero component is no problem.
    const auto p = sim->particles();
    double pscale = 0, lscale = 0;
    for (int i = 0; i < 2; ++i) {
      Eigen::Vector3d x(&p.position[3 * i]), v(&p.velocity[3 * i]), w(&p.angular_velocity[3 * i]);
      const double I = 0.4 * p.mass[i] * p.radius[i] * p.radius[i];
      pscale += p.mass[i] * v.norm();
      lscale += p.mass[i] * x.norm() * v.norm() + I * w.norm();
    }
    double worst_p = 0, worst_L = 0, max_contacts = 0, rot_change = 0;
    const double spin0 = sim->get("rotational_energy");
    for (int k = 0; k < 400; ++k) {
      sim->step_n(1);
      const Totals t = totals(*sim);
      for (int a = 0; a < 3; ++a) {
        worst_p = std::max(worst_p, std::abs(t.p[a] - t0.p[a]) / pscale);
        worst_L = std::max(worst_L, std::abs(t.L[a] - t0.L[a]) / lscale);
      }
      max_contacts = std::max(max_contacts, sim->get("contacts"));
      rot_change = std::max(rot_change, std::abs(sim->get("rotational_energy") - spin0));
    }
    INFO("mu = " << mu << ": worst relative change of momentum " << worst_p << ", of angular momentum " << worst_L);
    REQUIRE(max_contacts == 1.0);       // they did collide
    REQUIRE(sim->get("contacts") == 0.0);   // and separated
    CHECK(rot_change > 1e-3 * spin0);   // friction really acted on the spins
    CHECK(worst_p < 1e-12);
    CHECK(worst_L < 1e-12);
  }
}

TEST_CASE("extremes: save/restore in the middle of a frictional contact continues bit-for-bit", "[extremes][friction]") {
  for (int threads : {1, 2}) {
    // Small skin: the list is rebuilt during the contact, so the tangential history is carried too.
    const std::string text = oblique(0.3, threads, 0.002);
    auto a = make(text);
    long k = 0;
    while (a->get("contacts") == 0.0 && k < 10000) a->step_n(1), ++k;
    REQUIRE(a->get("contacts") == 1.0);
    a->step_n(20);   // well inside the contact, tangential spring loaded
    REQUIRE(a->get("contacts") == 1.0);
    const auto state = a->save_state();
    const double builds_at_save = a->get("neighbour_builds");
    a->step_n(150);   // through the end of the contact
    const auto reference = a->particles();
    const double reference_time = a->time();
    CHECK(a->get("neighbour_builds") > builds_at_save);

    auto b = make(text);   // a fresh simulation restored from the bytes
    b->restore_state(state);
    b->step_n(150);
    a->restore_state(state);   // and the original one, rewound
    a->step_n(150);
    for (const auto* sim : {b.get(), a.get()}) {
      const auto p = sim->particles();
      INFO("threads " << threads);
      CHECK(p.position == reference.position);
      CHECK(p.velocity == reference.velocity);
      CHECK(p.angular_velocity == reference.angular_velocity);
      CHECK(p.orientation == reference.orientation);
      CHECK(p.force == reference.force);
      CHECK(sim->time() == reference_time);
    }
  }
}



// Two grains closing at 2e4 cross each other within one step of t_c / 50: no overlap is ever seen, the
// collision is missed with nothing counted. The initial speeds are checked against the clamp depth per step.
TEST_CASE("extremes: initial speeds that close more than the clamp depth per step are warned about", "[extremes]") {
  auto pair_at = [](double speed) {
    ListedParticles p{{{0, 0, 0}, {1.2, 0, 0}}, {{speed / 2, 0, 0}, {-speed / 2, 0, 0}}, {1, 1}, {1, 1}};
    return make(listed_scene(3, p, {0.5, 0.1, 50, "global"}));   // dt = 0.002, clamp depth 1.0 R = 0.5
  };
  // Closing 0.498 a step: the onset is seen (the collision itself is clamped, which clamped_contacts counts).
  auto seen = pair_at(249);
  CHECK(seen->warnings().empty());
  auto missed = pair_at(2e4);
  REQUIRE(missed->warnings().size() == 1);
  CHECK_THAT(missed->warnings()[0], Contains("particles.velocities: the fastest initial grain moves at 10000") &&
                                        Contains("2 v_max dt = 40") && Contains("clamp depth contact.overlap_limit R_min = 0.5") &&
                                        Contains("keep time.dt below 2.5e-05"));
  missed->step_n(100);
  CHECK(missed->get("kinetic_energy") == Approx(1e8));   // what it warns about: the pair passed through unseen
  CHECK(missed->get("clamped_contacts_total") == 0);
}

// Doubles far from the origin are coarser than the contacts' overlaps: two grains 1e16 radii out kept their
// speeds and never moved. Coordinates whose spacing passes 1e-3 of the clamp depth are warned about; 1e8 radii
// out the collision is the one at the origin to 1e-6.
TEST_CASE("extremes: coordinates too far out for the contacts' overlaps are warned about", "[extremes]") {
  auto pair_at = [](double x) {
    ListedParticles p{{{x - 0.6, 0, 0}, {x + 0.6, 0, 0}}, {{0.5, 0, 0}, {-0.5, 0, 0}}, {1, 1}, {1, 1}};
    return make(listed_scene(3, p, {0.5, 0.1, 50, "global"}));   // clamp depth 1.0 R = 0.5
  };
  auto collide = [](Simulation& s) {
    s.step_n(500);
    return std::sqrt(s.get("kinetic_energy") / 0.25);
  };
  auto home = pair_at(0), near = pair_at(5e7);
  CHECK(home->warnings().empty());
  CHECK(near->warnings().empty());
  CHECK(collide(*near) == Approx(collide(*home)).epsilon(1e-5));
  auto far = pair_at(5e15);   // doubles 1 apart
  REQUIRE(far->warnings().size() == 1);
  CHECK_THAT(far->warnings()[0], Contains("particles.positions: coordinates reach 5e+15, where doubles are 1 apart") &&
                                     Contains("a scene near the origin, and no larger"));
  CHECK(collide(*far) == 1.0);   // what it warns about: they never met
  // The clamp depth is taken at most a tenth of R_min: at overlap_limit = 1 (the gas scenes') an elastic gas 1e12 out,
  // doubles 1.2e-4 apart, gains 0.9 % of its energy.
  auto gas_far = pair_at(1e12);
  REQUIRE(gas_far->warnings().size() == 1);
  CHECK_THAT(gas_far->warnings()[0], Contains("more than 1e-3 of the contacts' overlaps, min(contact.overlap_limit, 0.1) "
                                              "R_min = 0.05"));
  // Gravity without contacts is checked against the grains' radius or the softening length, whichever is smaller:
  // an eccentric binary of grains 0.001 across, 1e10 out, had lost 0.2 % of its angular momentum unwarned.
  auto binary_at = [](double x, double softening) {
    return make(fmt::format(R"(
[particles]
layout = "list"
positions = [[{0:.17g}, 0, 0], [{1:.17g}, 0, 0]]
velocity = "list"
velocities = [[0, -0.1147, 0], [0, 0.1147, 0]]
diameter = 0.001
mass = 0.5
[box]
periodic = false
[contact]
enabled = false
[gravity]
enabled = true
softening = {2}
[time]
dt = 0.001
)", x - 0.95, x + 0.95, softening));
  };
  const auto coarse = [](const Simulation& sim) {   // the one warning about coordinates, or ""
    const auto& w = sim.warnings();
    const auto it = std::find_if(w.begin(), w.end(), [](const std::string& x) { return x.find("coordinates reach") != x.npos; });
    return it == w.end() ? std::string() : *it;
  };
  auto orbit_far = binary_at(1e10, 0), orbit_home = binary_at(1e6, 0), orbit_soft = binary_at(1e9, 0.01);
  CHECK(warnings_of(*orbit_far, "coordinates reach") == 1);
  CHECK_THAT(coarse(*orbit_far), StartsWith("particles.positions: coordinates reach 1e+10") &&
                                     Contains("of the smallest radius R_min = 0.0005"));
  CHECK(coarse(*orbit_home).empty());
  CHECK_THAT(coarse(*orbit_soft), StartsWith("gravity.softening: coordinates reach") &&   // doubles 1.2e-7 apart
                                      Contains("of the softening length gravity.softening R_min = 5e-06") &&
                                      Contains("or raise gravity.softening"));
  // A random gas whose box a tiny solid fraction makes enormous: the fraction is named, not the unset box.lower.
  auto sparse = make(R"(
[scene]
dimension = 2
[particles]
layout = "random"
count = 20
diameter = 1.0
mass = 1.0
solid_fraction = 1e-30
[contact]
restitution = 0.5
duration = 0.1
)");
  REQUIRE(sparse->warnings().size() == 1);
  CHECK_THAT(sparse->warnings()[0], StartsWith("particles.solid_fraction: coordinates reach"));
}

// At a fixed t_c the spring stiffens as ln^2 e: at e = 1e-20 and 50 steps per contact the head-on pair parted at
// 0.028 against the clamped law's 0.136, warned only about dense packings. The warning now says the collision
// itself is off, and from how many steps per contact it is not (the t_c / 20 rule's resolution, asked of the
// undamped frequency).
TEST_CASE("extremes: a restitution so small that one collision is unresolved says so", "[extremes]") {
  auto pair = [](double e, double nc) {
    ListedParticles p{{{0, 0, 0}, {1.1, 0, 0}}, {{1, 0, 0}, {0, 0, 0}}, {1, 1}, {1, 1}};
    return make(listed_scene(3, p, {e, 0.1, nc, "global"}));
  };
  auto coarse = pair(1e-20, 50);
  REQUIRE(coarse->warnings().size() == 1);
  CHECK_THAT(coarse->warnings()[0], Contains("damped contacts") && Contains("a binary collision of the lightest pair is off too") &&
                                        Contains("(time.steps_per_contact 294)") && Contains("the collision is unstable"));
  HeadOn h;
  h.e = 1e-20, h.tc = 0.1, h.nc = 50;
  bool finite = true;
  const double exact = clamped_for(1e-20, 0.1, 0.5, 0.5);
  CHECK(std::abs(realised_restitution(h, finite) / exact - 1) > 0.5);   // what it warns about
  auto fine = pair(1e-20, 330);
  REQUIRE(fine->warnings().size() == 1);   // the packing's limit still (it asks 649 steps per contact)
  CHECK_THAT(fine->warnings()[0], !Contains("binary collision"));
  h.nc = 330;
  CHECK(realised_restitution(h, finite) == Approx(exact).epsilon(0.005));
  CHECK_THAT(pair(1e-6, 50)->warnings()[0], Contains("(time.steps_per_contact 91)") && !Contains("unstable"));   // 5 % off
  auto mild = pair(1e-3, 50);   // 1e-3 off
  for (const auto& w : mild->warnings()) CHECK_THAT(w, !Contains("binary collision"));
}

// Found by fuzzing (tests/fuzz/fuzz_particle_file): the set-up's cell grids (random insertion, the initial overlap
// check) convert L / d to an integer, beyond its range for grains 1e-30 wide in a box of 10 (undefined behaviour,
// which UBSan reports) unless they keep to at most 1e6 cells an axis.
TEST_CASE("extremes: grains 1e-30 wide in a box of 10 are set up and step", "[extremes]") {
  for (const std::string layout : {"lattice", "random"}) {
    INFO(layout);
    auto sim = make(fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "{}"
count = 8
diameter = 1e-30
[box]
lengths = [10.0, 10.0, 10.0]
[contact]
restitution = 0.5
duration = 0.05
[run]
threads = 1
)", layout));
    sim->step_n(3);
    CHECK(sim->particles().radius[0] == 0.5e-30);
  }
}

TEST_CASE("extremes: a gravitational constant whose closest pair force overflows is named as the cause", "[extremes][gravity]") {
  // gravity.G = 1e308 is in range; the failure must name it, not only the particle and "coincident or deeply
  // overlapping particles".
  const auto scene = [](const char* G) {
    return Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/aggregation.toml",
                            {"run.threads=1", fmt::format("gravity.G={}", G)});
  };
  REQUIRE_THROWS_WITH(Simulation::create(scene("1e308")),
                      Contains("non-finite") && Contains("gravity.G = 1e+308") && Contains("lower gravity.G"));
  auto fine = Simulation::create(scene("1.0"));
  fine->step_n(10);
  CHECK(std::isfinite(fine->get("kinetic_energy")));
  // Without softening the closest pair's force has no bound: coincident grains under a tiny G are not G's doing.
  const auto unsoftened = Scene::from_string(
      "[scene]\nname = \"nosoft\"\ndimension = 3\n[particles]\nlayout = \"list\"\n"
      "positions = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [3.0, 0.0, 0.0]]\ndiameter = 1.0\nmass = 1.0\n"
      "[box]\nperiodic = false\n[contact]\nenabled = false\n[gravity]\nenabled = true\nG = 1e-30\nsoftening = 0.0\n"
      "[time]\ndt = 0.001\nduration = 0.01\n",
      "nosoft");
  try {
    auto sim = Simulation::create(unsoftened);
    sim->step_n(10);
    FAIL("coincident unsoftened grains did not fail");
  } catch (const SimulationError& e) {
    CHECK_THAT(e.what(), Contains("non-finite") && !Contains("lower gravity.G"));
  }
}

TEST_CASE("extremes: energies that overflow while every particle stays finite stop the run, not inf in the outputs",
          "[extremes][gravity]") {
  // Two heavy, wide spheres falling through each other's softened core at a step 30 times their orbit's: each pass
  // gains energy until ½ m v² overflows while v does not; unstopped, the outputs would read inf and the run go on.
  // The stepping call that overflows stops (as a host's step does), whether or not anything reads the outputs.
  auto sim = make(R"(
[scene]
dimension = 3
[particles]
layout = "list"
positions = [[0, 0, 0], [3e10, 0, 0]]
diameters = [1e10, 1e10]
masses = [1e150, 1e150]
[box]
periodic = false
[contact]
enabled = false
[gravity]
enabled = true
G = 5e17
[time]
dt = 1e-70
)");
  CHECK(std::isfinite(sim->get("kinetic_energy")));
  try {
    for (int k = 0; k < 20; ++k) {
      sim->step_n(100);   // or the error below
      const double K = sim->get("kinetic_energy"), W = sim->get("gravity_potential_energy");
      INFO("after " << sim->step_count() << " steps");
      REQUIRE((std::isfinite(K) && std::isfinite(W)));
    }
    FAIL("the energy stayed finite for 2000 steps: the case no longer overflows");
  } catch (const SimulationError& e) {
    INFO(e.what());
    CHECK_THAT(e.what(), Contains("the kinetic energy overflows a double at step") &&
                             Contains("the particle of the largest kinetic energy is 0") && Contains("kinetic energy inf"));
  }
}
