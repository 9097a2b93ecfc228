// The tangential and rolling springs and dashpots of a sticking contact are integrated on the half-step
// velocity, stable only for k h^2 / m + 2 c h / m <= 4; the normal time-step rule does not see them, and
// their ratios to the normal law are open-ended. Past that step a frictional collision gained a thousand
// times its energy, unwarned; now the step is named, and below it the collision stays passive.
#include <catch2/catch.hpp>

#include <string>

#include <fmt/format.h>

#include "adhesive_scene.hpp"
#include "core/simulation.hpp"
#include "head_on_scene.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Contains;

namespace {
// Two unit spheres (m* = 1/2, tangential mass m* / 3.5) in an oblique, elastic, sticking (mu = 1e3)
// collision at 50 steps of t_c = 0.1: the bound is k_t = 289 k_n at c_t = 0.
std::unique_ptr<Simulation> oblique(double stiffness_ratio, double damping_ratio, double restitution = 1.0) {
  ListedParticles p{{{0, 0, 0}, {1.1, 0.4, 0}}, {{1, 0, 0}, {0, 0, 0}}, {1, 1}, {1, 1}};
  return Simulation::create(Scene::from_string(
      listed_scene(3, p, {restitution, 0.1, 50, "global"}) +
          fmt::format("[friction]\ncoefficient = 1000\nstiffness_ratio = {}\ndamping_ratio = {}\n", stiffness_ratio, damping_ratio),
      "oblique"));
}
double collide(Simulation& s) {
  const double before = s.get("kinetic_energy");
  s.step_n(400);
  REQUIRE(s.get("contacts") == 0);
  return s.get("kinetic_energy") / before;
}
}  // namespace

TEST_CASE("a tangential spring or dashpot too stiff for the step is warned about", "[extremes][friction]") {
  auto stable = oblique(250, 0);
  CHECK(stable->warnings().empty());
  CHECK(collide(*stable) < 1.05);   // stable (resolved by under 3 steps a period: not accurate, no gain to speak of)
  auto stiff = oblique(330, 0);
  REQUIRE(stiff->warnings().size() == 1);
  CHECK_THAT(stiff->warnings()[0], Contains("friction.stiffness_ratio = 330") && Contains("time.dt = 0.002 exceeds 0.00187") &&
                                       Contains("tangential spring and dashpot are stable"));
  auto stiffer = oblique(1e4, 0);
  CHECK(stiffer->warnings().size() == 1);
  CHECK(collide(*stiffer) > 2);   // what it warns of
  // The dashpot alone: c_t h / m_t beyond 2 (e = 0.5, c_t = 30 c_n).
  auto damped = oblique(1, 30, 0.5);
  REQUIRE(damped->warnings().size() == 1);
  CHECK_THAT(damped->warnings()[0], Contains("friction.damping_ratio = 30"));
  CHECK(oblique(1, 3, 0.5)->warnings().empty());
  CHECK_THAT(damped->warnings()[0], Contains("lower the ratio or the step (time.steps_per_contact"));
  // A ratio no step can follow: the bound computed without overflow (not "exceeds 0", with c_t^2 = inf), and only
  // the ratio offered as the remedy (not "time.steps_per_contact inf or more").
  auto absurd = oblique(1, 1e300, 0.5);
  REQUIRE(absurd->warnings().size() == 1);
  CHECK_THAT(absurd->warnings()[0], Contains("friction.damping_ratio = 1e+300") && !Contains("exceeds 0,") &&
                                        Contains("lower the ratio (no practical step is below it") && !Contains("inf"));
  // And a vanishing ratio is no ratio: 4 k m / c^2 would overflow there.
  CHECK(oblique(1, 1e-200, 0.5)->warnings().empty());
}

TEST_CASE("a rolling spring too stiff for the step is warned about", "[extremes][rolling]") {
  // Two unit disks of the consolidation law bonded at rest; I = 1/8, the pair's 1/16; K_R = ratio K_N.
  ListedParticles p{{{0, 0}, {1 - 1e-5, 0}}, {{0, 0}, {0, 0}}, {1, 1}, {1, 1}};
  auto bonded = [&](double ratio) {
    return Simulation::create(Scene::from_string(
        adhesive_scene(2, p, fmt::format("[rolling]\ncoefficient = 1000\nstiffness_ratio = {}\n", ratio)), "bond"));
  };
  CHECK(bonded(1e-4)->warnings().empty());
  // w h = sqrt(ratio K_N / (1/16)) pi sqrt(0.5 / K_N) / 50 = 0.178 sqrt(ratio): a lone pair's bound 2 at ratio 126. The
  // rule assumes every grain has as many contacts as fit (6 equal disks; I* = I / 12, not I / 2), so it warns from
  // ratio 21: cautious for this pair, but a triangular lattice of such disks gained 12 and 35 times its kinetic
  // energy in 20,000 steps at ratios 60 and 100, where a one-contact rule says nothing.
  CHECK(bonded(15)->warnings().empty());
  auto stiff = bonded(30);
  REQUIRE(stiff->warnings().size() == 1);
  CHECK_THAT(stiff->warnings()[0], Contains("rolling.stiffness_ratio = 30") && Contains("rolling springs and dashpots are stable") &&
                                       Contains("up to 6 contacts"));
}

TEST_CASE("a rolling dashpot too strong for a small grain between large ones is warned about, spring or none",
          "[extremes][rolling]") {
  // A disk of diameter 0.05 bonded between two of diameter 1, spinning. A rule looking at the two smallest grains
  // only, one contact each, and only with a rolling spring, misses it: rolling.damping_ratio = 1 (the schema's stated
  // stable maximum) blows it up, and the error blames the initial state; so does 0.45, which a rule for a single pair
  // allows. The small grain's spin feels both dashpots: its limit is half a pair's,
  // 0.249 in 2D and 0.199 in 3D at this step (the two contacts the geometry allows; 0.3 and 0.25 blow up).
  for (const int dim : {2, 3}) {
    INFO("dimension " << dim);
    const double m = dim == 2 ? 0.0025 : 1.25e-4;   // the small grain at the large ones' density
    const auto at = [dim](double x) {
      std::vector<double> r(dim, 0.0);
      r[0] = x;
      return r;
    };
    ListedParticles p{{at(-0.52499), at(0), at(0.52499)}, {at(0), at(0), at(0)}, {1, 0.05, 1}, {1, m, 1}};
    const std::string spin = dim == 2 ? "angular_velocities = [[0], [1], [0]]"
                                      : "angular_velocities = [[0, 0, 0], [0, 0, 1], [0, 0, 0]]";
    const auto grains = [&](double beta) {
      return Simulation::create(Scene::from_string(
          adhesive_scene(dim, p, fmt::format("[rolling]\ndamping_ratio = {}\n", beta), spin), "between"));
    };
    auto strong = grains(dim == 2 ? 0.3 : 0.25);
    REQUIRE(strong->warnings().size() == 1);
    CHECK_THAT(strong->warnings()[0], Contains("(no rolling spring") && Contains("worst grain (particle 1, radius 0.025") &&
                                          Contains("up to 2 contacts to grains like particle 0, radius 0.5") &&
                                          Contains(dim == 2 ? "at or below 0.249," : "at or below 0.199,"));
    CHECK_THROWS_AS(strong->step_n(20000), SimulationError);   // the warning is no false alarm
    auto held = grains(0.15);
    CHECK(held->warnings().empty());
    held->step_n(20000);
    CHECK(std::abs(held->particles().angular_velocity[dim == 2 ? 1 : 5]) < 1.0);   // the spin damped, not grown
    // Set by a host (or the programme's quench) while stepping: checked then, once.
    auto steered = grains(0.1);   // (with 0 and no cell the scene has no rolling module to steer)
    REQUIRE(steered->warnings().empty());
    steered->step_n(10);
    const auto beta = steered->index_of("rolling.damping_ratio");
    steered->set(beta, 1.0);
    steered->set(beta, 0.9);
    REQUIRE(steered->warnings().size() == 1);
    CHECK_THAT(steered->warnings()[0], Contains("rolling.damping_ratio = 1 (set at t = ") && Contains("step 10)") &&
                                           Contains("or programme.quench_damping where the programme's quench sets it"));
  }
}
