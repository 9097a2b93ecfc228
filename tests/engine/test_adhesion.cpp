// The adhesive contact law (physics.md section 6) against its closed forms: the equilibrium gap of a
// bonded pair, the pull-off force, and the escape speed V* sqrt(2) of two unit-mass disks.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "adhesive_scene.hpp"
#include "core/simulation.hpp"
#include "interactions/normal_calibration.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {
// Table I in units a = 1, F0 = 1, m = 1 (unit-mass disks of diameter a).
constexpr double F0 = 1.0, KN = 1e5, D0 = 1e-3;

// Two unit-mass grains of diameter 1 on the x axis at surface gap `gap`, receding at relative speed `speed`.
ListedParticles pair(int dim, double gap, double speed) {
  auto along_x = [dim](double x) {
    std::vector<double> r(dim, 0.0);
    r[0] = x;
    return r;
  };
  ListedParticles p;
  p.positions = {along_x(0), along_x(1 + gap)};
  p.velocities = {along_x(-speed / 2), along_x(speed / 2)};
  p.diameters = {1, 1};
  p.masses = {1, 1};
  return p;
}

double gap_of(const Simulation& s) {
  const auto v = s.particles();
  const int D = v.dimension;
  double d2 = 0;
  for (int a = 0; a < D; ++a) d2 += std::pow(v.position[D + a] - v.position[a], 2);
  return std::sqrt(d2) - 1.0;
}
double receding_speed(const Simulation& s) {
  const auto v = s.particles();
  return v.velocity[v.dimension] - v.velocity[0];
}
}  // namespace

TEST_CASE("a bonded pair settles at the equilibrium overlap F0 / K_N", "[adhesion]") {
  for (int dim : {2, 3}) {
    auto s = Simulation::create(Scene::from_string(adhesive_scene(dim, pair(dim, 0.0, 0.0)), "bond"));
    const double tc = std::numbers::pi * std::sqrt(0.5 / KN);
    CHECK(s->dt() == Approx(tc / 50).epsilon(1e-12));
    s->step(200 * tc);
    INFO("dimension " << dim);
    CHECK(-gap_of(*s) == Approx(F0 / KN).epsilon(1e-9));
    CHECK(std::abs(receding_speed(*s)) < 1e-12);
    CHECK(s->get("contacts") == 1);
    // Energy at rest: K_N delta0^2 / 2 in the spring, -F0 D0 / 2 - F0 delta0 in the attraction.
    CHECK(s->get("elastic_energy") == Approx(0.5 * F0 * F0 / KN).epsilon(1e-8));
    CHECK(s->get("adhesion_energy") == Approx(-0.5 * F0 * D0 - F0 * F0 / KN).epsilon(1e-10));
  }
}

TEST_CASE("the static normal force: the largest tension a bond carries (pull-off force) is F0", "[adhesion]") {
  const double delta0 = F0 / KN;
  struct Case { double gap, force; };   // force on j along n, positive = repulsive
  const Case cases[] = {{-2 * delta0, F0},      {-delta0, 0.0},        {-0.5 * delta0, -0.5 * F0}, {-1e-9, -F0 + 1e-4},
                        {0.25 * D0, -0.75 * F0}, {0.5 * D0, -0.5 * F0}, {0.999 * D0, -1e-3 * F0},  {1.001 * D0, 0.0},
                        {0.1, 0.0}};
  double largest_tension = 0;
  for (const auto& c : cases) {
    auto s = Simulation::create(Scene::from_string(adhesive_scene(2, pair(2, c.gap, 0.0)), "static"));
    const double f = s->particles().force[2];   // x component on the right-hand grain
    INFO("gap " << c.gap);
    CHECK(f == Approx(c.force).margin(1e-9));
    CHECK(s->particles().force[0] == -f);
    largest_tension = std::max(largest_tension, -f);
  }
  CHECK(largest_tension == Approx(F0).epsilon(1e-3));
}

// Receding from contact at gap 0, the pair must climb the attraction's potential well F0 D0 / 2 with
// its relative kinetic energy m* V^2 / 2, m* = 1/2: it escapes when V > sqrt(2 F0 D0 / m) = V* sqrt(2).
TEST_CASE("two unit-mass disks separate only above the receding speed V* sqrt(2)", "[adhesion]") {
  const double v_star = std::sqrt(F0 * D0 / 1.0);
  const double escape = v_star * std::sqrt(2.0);
  const double horizon = 40 * D0 / escape;   // long enough to cross the range or to fall back into contact
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    for (double ratio : {0.99, 1.01, 1.1}) {
      INFO("speed / (V* sqrt 2) = " << ratio);
      auto s = Simulation::create(Scene::from_string(adhesive_scene(dim, pair(dim, 0.0, ratio * escape)), "escape"));
      s->step(horizon);
      if (ratio < 1) {
        CHECK(gap_of(*s) < D0);   // recaptured: back within the range (it falls into contact and stays)
        s->step(horizon);
        CHECK(gap_of(*s) < 0);
      } else {
        CHECK(gap_of(*s) > D0);
        // Energy balance beyond the range: V_final^2 = V^2 - 2 F0 D0 / m. Measured 2.5e-4 at 1.01 and 2.7e-5
        // at 1.1 (the final speed magnifies the energy error most just above the escape speed).
        const double final_error = receding_speed(*s) / (escape * std::sqrt(ratio * ratio - 1)) - 1;
        WARN(fmt::format("{}D escape at {} V* sqrt 2: final speed relative error {:.2g}", dim, ratio, final_error));
        CHECK(std::abs(final_error) < (ratio > 1.05 ? 1e-4 : 1e-3));
      }
    }
  }
}

TEST_CASE("bad adhesion and rolling input is named", "[adhesion][scene]") {
  auto p = pair(2, 0.0, 0.0);
  CHECK_THROWS_WITH(Simulation::create(Scene::from_string(adhesive_scene(2, p, "[rolling]\ncoefficient = -1"), "bad")),
                    Catch::Contains("rolling.coefficient") && Catch::Contains("-1"));
  CHECK_THROWS_WITH(Simulation::create(Scene::from_string(adhesive_scene(2, p, "", "") + "\n[contact]\nenabled = false", "bad")),
                    Catch::Contains("adhesion.enabled") && Catch::Contains("contact.enabled"));
  auto no_adhesion = adhesive_scene(2, p, "[rolling]\ncoefficient = 0.005");
  no_adhesion.replace(no_adhesion.find("enabled = true"), 14, "enabled = false");
  CHECK_THROWS_WITH(Simulation::create(Scene::from_string(no_adhesion + "[contact]\nduration = 1\n", "bad")),
                    Catch::Contains("rolling.coefficient") && Catch::Contains("adhesion.enabled"));
  CHECK_THROWS_WITH(Simulation::create(Scene::from_string(adhesive_scene(2, p, "[rolling]\nstiffness_ratio = 0"), "bad")),
                    Catch::Contains("rolling.stiffness_ratio"));
}

// The clamp caps the elastic force at K_N f_max R_min = 1e5 * 0.1 * 0.5 = 5000 here: an attraction that reaches
// it has no rest overlap, and two grains meeting at 0.2 sank to within 2e-4 of each other, gaining energy.
TEST_CASE("an attraction the clamped contact cannot balance is refused, naming the field, value and bound", "[adhesion][scene]") {
  auto p = pair(2, 0.2, -0.2);
  for (const char* force : {"5000", "10000"})
    CHECK_THROWS_WITH(Simulation::create(Scene::from_string(adhesive_scene(2, p, fmt::format("force = {}\n", force)), "bad")),
                      Catch::Contains(fmt::format("adhesion.force: value {}", force)) &&
                          Catch::Contains("not below K_N f_max R_min = 5000") && Catch::Contains("allowed [0, 5000)"));
  // Below the cap the bond holds, at its rest overlap F0 / K_N = 0.04 (the clamp's f_max R_min is 0.05).
  auto s = Simulation::create(Scene::from_string(adhesive_scene(2, p, "force = 4000\n"), "holds"));
  s->step(1.0 + 100 * s->dt() * 50);
  CHECK(-gap_of(*s) == Approx(4000 / KN).epsilon(1e-6));
  // The same attraction is allowed where the clamp leaves room for its rest overlap 0.1.
  CHECK_NOTHROW(Simulation::create(Scene::from_string(adhesive_scene(2, p, "force = 1e4\n") + "[contact]\noverlap_limit = 0.5\n", "room")));
}

#include "core/system.hpp"
#include "interactions/adhesive_contact_law.hpp"
#include "interactions/contact_forces.hpp"

// The stress of a cohesive packing counts the attraction: a contact pulled at -F0 / 2 across half
// the range, and one bonded at the equilibrium overlap, contribute F (x) r with F = -F0 / 2 n and 0.
TEST_CASE("the contact virial includes the adhesive forces", "[adhesion][stress]") {
  for (int threads : {1, 2}) {
    System<2> s;
    const double delta0 = F0 / KN;
    const std::vector<Vec<2>> x = {{0, 0}, {1 + 0.5 * D0, 0}, {0, 1 - delta0}};
    s.particles.resize(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) s.particles.position[i] = x[i], s.particles.set_mass_and_radius(i, 1.0, 0.5);
    s.box.length = Vec<2>(8.0, 8.0);
    s.box.periodic.fill(true);
    s.threads = threads;
    s.thread_force.assign(threads, std::vector<Vec<2>>(x.size(), Vec<2>::Zero()));
    s.thread_torque.assign(threads, std::vector<Spin<2>>(x.size(), Spin<2>::Zero()));
    AdhesiveContactLaw law{KN, F0, D0, 0.8, 0.1};
    s.neighbours.configure(law.reach(), 0.1);
    s.neighbours.build(s.particles.position, s.particles.radius, s.box, threads);
    ContactForces<2, AdhesiveContactLaw, CoulombFriction> contacts(law, CoulombFriction{0.5, 1.0, 0.0, true});
    s.want_virial = true;
    contacts.add_forces(s);
    CHECK(s.virial(0, 0) == Approx(-0.5 * F0 * (1 + 0.5 * D0)).epsilon(1e-12));
    CHECK(std::abs(s.virial(1, 1)) < 1e-9);
    CHECK(s.virial(0, 1) == 0);
  }
}

namespace {
// A bonded pair (unit masses, m* = 1/2) at its equilibrium overlap delta0 = F0 / K_N receding at speed V:
// in contact, y = delta - delta0 follows the damped oscillator y'' + 2 zeta w0 y' + w0^2 y = 0, so
// y = -(V / w_d) exp(-zeta w0 t) sin(w_d t); the surfaces part where y = -delta0, at speed -y'. Returns
// that parting speed and time, or speed 0 when y turns back before reaching -delta0 (the bond holds).
struct Parting { double speed, time; };
Parting exact_parting(double V) {
  const double mstar = 0.5, zeta = grains::damping_ratio(0.015), w0 = std::sqrt(KN / mstar);
  const double a = zeta * w0, wd = w0 * std::sqrt(1 - zeta * zeta), delta0 = F0 / KN;
  auto y = [&](double t) { return -V / wd * std::exp(-a * t) * std::sin(wd * t); };
  const double t_turn = std::atan2(wd, a) / wd;   // y' = 0: the deepest point of the pull
  if (y(t_turn) > -delta0) return {0.0, t_turn};
  double lo = 0, hi = t_turn;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (y(mid) > -delta0 ? lo : hi) = mid;
  }
  const double t = 0.5 * (lo + hi);
  return {V * std::exp(-a * t) * (std::cos(wd * t) - a / wd * std::sin(wd * t)), t};
}
double exact_parting_speed(double V) { return exact_parting(V).speed; }

// The initial receding speed whose exact parting speed is `target` (the parting speed grows with V).
double speed_for_parting_speed(double target) {
  double lo = 0, hi = 100 * target;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (exact_parting_speed(mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// Final receding speed of the bonded pair started at speed V (0 if recaptured), at n_c steps per contact.
double final_speed(int dim, double V, double nc) {
  auto s = Simulation::create(
      Scene::from_string(adhesive_scene(dim, pair(dim, -F0 / KN, V), fmt::format("[time]\nsteps_per_contact = {}\n", nc)),
                         "parting"));
  s->step(40 * D0 / std::sqrt(F0 * D0));
  return gap_of(*s) > D0 ? receding_speed(*s) : 0.0;
}
}  // namespace

// The bonded pair's dashpot acts only in contact: its force c_n v_n drops to zero when the surfaces
// part, within a step. Against the exact piecewise solution (damped oscillator in contact, then the
// energy balance across the attraction range, V_final^2 = V_p^2 - 2 V*^2): the pair escapes exactly
// when its parting speed V_p exceeds V* sqrt(2), and the final speed converges at second order.
TEST_CASE("a bonded pair pulled apart: escape threshold and final speed against the exact solution", "[adhesion]") {
  const double escape = std::sqrt(2 * F0 * D0);
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    for (double ratio : {0.99, 1.01}) {
      INFO("parting speed / (V* sqrt 2) = " << ratio);
      const double v = final_speed(dim, speed_for_parting_speed(ratio * escape), 50);
      // At 1.01 the final speed magnifies an error in the parting energy 50 times: 3 % (28 % when the
      // dashpot was charged over the whole last window).
      if (ratio < 1) CHECK(v == 0.0);
      else CHECK(v == Approx(escape * std::sqrt(ratio * ratio - 1)).epsilon(3e-2));
    }
  }
  // Order: worst relative error of the final speed over parting speeds 1.05 .. 1.4 V* sqrt 2 (the
  // parting falls at different points of a step) at n_c = 50, 100, 200.
  std::vector<double> worst;
  for (double nc : {50.0, 100.0, 200.0}) {
    double w = 0;
    for (double ratio = 1.05; ratio < 1.41; ratio += 0.05) {
      const double v = final_speed(2, speed_for_parting_speed(ratio * escape), nc);
      w = std::max(w, std::abs(v / (escape * std::sqrt(ratio * ratio - 1)) - 1));
    }
    worst.push_back(w);
  }
  WARN(fmt::format("bonded pair pulled apart: worst relative error of the final speed at n_c = 50, 100, 200: "
                   "{:.2e} {:.2e} {:.2e}; observed orders {:.2f} {:.2f}", worst[0], worst[1], worst[2],
                   std::log2(worst[0] / worst[1]), std::log2(worst[1] / worst[2])));
  CHECK(worst[0] < 1e-2);
  CHECK(std::log2(worst[0] / worst[1]) >= 1.8);
  CHECK(std::log2(worst[1] / worst[2]) >= 1.8);
}

// A bond present at the start that parts within the first step: the initial force evaluation is charged over
// the first half kick only, so its parting correction differs from a later step's (contact_step.hpp). Without it
// the final speed is 3.5 % high for parting at 0.74 of the step, 1.3 % low at 0.38.
TEST_CASE("a bond present at the start and parting within the first step leaves at the exact speed", "[adhesion]") {
  const double escape = std::sqrt(2 * F0 * D0), nc = 50;
  const double dt = M_PI * std::sqrt(0.5 / KN) / nc;   // t_c / n_c, t_c of the pair (m* = 1/2)
  double worst = 0;
  for (int dim : {2, 3})
    for (double share : {0.2, 0.38, 0.5, 0.74, 0.9}) {
      double lo = 0, hi = 10;   // the receding speed whose exact parting falls at share * dt (earlier when faster)
      for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        (exact_parting(mid).time > share * dt ? lo : hi) = mid;
      }
      const double V = 0.5 * (lo + hi), parting_speed = exact_parting_speed(V);
      REQUIRE(parting_speed > 1.5 * escape);
      const double exact = std::sqrt(parting_speed * parting_speed - escape * escape);
      const double error = final_speed(dim, V, nc) / exact - 1;
      INFO(dim << "D, parting at " << share << " of the first step: relative error " << error);
      worst = std::max(worst, std::abs(error));
      CHECK(std::abs(error) < 1e-3);   // measured 4e-6 (0.2) to 3.2e-4 (0.9), n_c = 50
    }
  WARN(fmt::format("bond parting within the first step: worst relative error of the final speed {:.2e}", worst));
}

namespace {

// The realised e_N of two disks of masses m1 and m2 (diameter 1) meeting head-on at relative speed 0.2 with zero
// total momentum, their centres starting at -+x, under the adhesive law with F0 = 0 and D0 = 0 (the cohesionless
// reference law), n_c = 50.
double cohesionless_restitution(double x, double m1, double m2, double e) {
  const double v1 = 0.2 * m2 / (m1 + m2), v2 = -0.2 * m1 / (m1 + m2);
  const std::string scene = fmt::format(R"(
[scene]
dimension = 2
[particles]
layout = "list"
positions = [[{:.17g}, 0], [{:.17g}, 0]]
velocity = "list"
velocities = [[{:.17g}, 0], [{:.17g}, 0]]
diameter = 1.0
masses = [{:.17g}, {:.17g}]
[box]
periodic = false
[adhesion]
enabled = true
force = 0.0
range = 0.0
stiffness = 1e5
restitution = {}
[time]
steps_per_contact = 50
[run]
threads = 1
)", -x, x, v1, v2, m1, m2, e);
  auto s = Simulation::create(Scene::from_string(scene, "pair"));
  s->step_n(long(std::ceil(1.0 / s->dt())));
  const ParticleView p = s->particles();
  return (p.velocity[2] - p.velocity[0]) / 0.2;
}

}  // namespace

TEST_CASE("a cohesionless binary collision realises e_N wherever in a step the disks touch", "[adhesion]") {
  // The parting charge is made at the last overlapping evaluation from a predicted parting; a pair predicted to
  // part just before the next evaluation but still overlapping there was charged twice: e_N came out 1.3 % low
  // at e_N = 0.5 and up to 5.5 % low at 0.015 for touching times in a few per cent of a step. Now the next
  // evaluation takes the charge back (contact_forces.hpp).
  const double dt = std::acos(-1.0) * std::sqrt(0.5 / 1e5) / 50;
  for (double e : {0.5, 0.015}) {
    double worst = 0;
    for (int phase = 0; phase < 40; ++phase)   // touching at t = (x - 0.5) / 0.1: 40 points of a step
      worst = std::max(worst, std::abs(cohesionless_restitution(0.55 + phase / 40.0 * 0.1 * dt, 1, 1, e) / e - 1));
    INFO("e_N = " << e);
    CHECK(worst < 1e-3);   // measured 1.6e-4 (0.5) and 5.7e-4 (0.015); 1.3e-2 and 5.5e-2 before
  }
}

TEST_CASE("a cohesionless binary collision of unequal masses realises e_N: the dashpot takes the pair's reduced mass",
          "[adhesion]") {
  // Masses 1 and 4 (m* = 0.8). Every other test of the law collides equal masses, where m_i m_j / (m_i + m_j) and
  // (m_i + m_j) / 4 agree: a dashpot from the wrong mass passed them all (a review's seeded bug).
  for (double e : {0.5, 0.015}) {
    double worst = 0;
    for (int phase = 0; phase < 5; ++phase)
      worst = std::max(worst, std::abs(cohesionless_restitution(0.55 + phase * 1e-6, 1, 4, e) / e - 1));
    INFO("e_N = " << e);
    CHECK(worst < 1e-3);   // measured 1.6e-4 (0.5) and 4.6e-4 (0.015)
  }
}
