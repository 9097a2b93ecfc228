// The energy check (physics.md section 3: nothing blows up silently): in a gravity scene nothing adds energy,
// so E = K + W + elastic may only fall; a rise above 1 % of max(K, |W|, |E_0|) over its lowest value is warned
// about, once, where the outputs are computed. Soft contacts (k* = 10, the overlap cap k_n delta_max below the
// gravitational pull) let grains pass through each other, and the step then makes energy; the pass-through check
// warns of an overlap past the smaller radius, which a cloud whose dashpots take the released energy reaches unheated.
#include <catch2/catch.hpp>

#include <algorithm>
#include <string>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "warnings_of.hpp"

using namespace grains;
using Catch::Matchers::Contains;

namespace {

// Two unit spheres (diameter 1, mass 1, G = 1, eps = 0.1 R) approaching head-on at 1 each from 3 apart (a
// slight offset), 30 steps per contact. e = 0.939 is the sweep's zeta = 0.02; t_c = 0.4968 gives k* = 10 (as soft
// as the sweep's softest column), t_c = 0.005 gives k* ~ 1e5.
std::string two_grains(double duration) {
  return fmt::format(R"(
[particles]
layout = "list"
positions = [[0, 0, 0], [3.0, 0.02, 0]]
diameters = [1.0, 1.0]
masses = [1.0, 1.0]
velocity = "list"
velocities = [[1.0, 0, 0], [-1.0, 0, 0]]
[box]
periodic = false
[contact]
restitution = 0.9390895628611485
duration = {:.17g}
[gravity]
enabled = true
G = 1.0
softening = 0.1
[time]
steps_per_contact = 30
[run]
threads = 1
)", duration);
}

long energy_warnings(const Simulation& sim) { return warnings_of(sim, "energy check"); }

double total_energy(const Simulation& sim) {
  return sim.get("kinetic_energy") + sim.get("gravity_potential_energy") + sim.get("elastic_energy");
}

// Runs `steps`, reading the outputs (which runs the check) every `every` steps, as the runner does at its
// observable times; returns the lowest and the last E read.
std::pair<double, double> run_reading(Simulation& sim, long steps, long every) {
  double lowest = total_energy(sim), last = lowest;
  for (long done = 0; done < steps; done += every) {
    sim.step_n(std::min(every, steps - done));
    last = total_energy(sim);
    lowest = std::min(lowest, last);
  }
  return {lowest, last};
}

}  // namespace

TEST_CASE("energy check: two soft grains passing through each other are warned about, once", "[gravity][energy]") {
  auto sim = Simulation::create(Scene::from_string(two_grains(0.49682878898616584), "pass"));
  CHECK(sim->get("normalised_stiffness") == Approx(10).epsilon(1e-9));
  // The start-up orbit rule does not take the contacts for a wall: d = 0, and dt = t_c / 30 is past T_orb / 20.
  REQUIRE(sim->warnings().size() == 1);
  CHECK_THAT(sim->warnings()[0], Contains("T_orb") && Contains("d = 0 ") && Contains("cannot keep grains apart"));
  const double E0 = total_energy(*sim);
  const auto [lowest, last] = run_reading(*sim, 362, 10);   // 6 time units
  INFO("E0 " << E0 << ", lowest " << lowest << ", last " << last);
  CHECK(last > E0 + 1);   // the energy blew up (0.67 -> 18)
  REQUIRE(energy_warnings(*sim) == 1);
  const std::string& w = *std::find_if(sim->warnings().begin(), sim->warnings().end(),
                                       [](const std::string& x) { return x.starts_with("energy check"); });
  CHECK_THAT(w, Contains("energy check: at t = ") && Contains("t_ff") && Contains("k* = 10") &&
                    Contains("contacts too soft for the gravitational load") && Contains("time.steps_per_contact"));
  // Once: more of the same run, read as often, adds no second one; nor does a simulation restored from its state.
  run_reading(*sim, 100, 10);
  CHECK(energy_warnings(*sim) == 1);
  auto restored = Simulation::create(Scene::from_string(two_grains(0.49682878898616584), "pass"));
  restored->restore_state(sim->save_state());
  run_reading(*restored, 100, 10);
  CHECK(energy_warnings(*restored) == 0);
  // At 300 steps per contact the same encounter loses energy, as it should, and nothing is warned about.
  auto fine = Simulation::create(Scene::from_string(two_grains(0.49682878898616584), "fine",
                                                    {"time.steps_per_contact=300"}));
  const auto [fine_lowest, fine_last] = run_reading(*fine, 3620, 10);
  CHECK(fine_last < E0);
  CHECK(energy_warnings(*fine) == 0);
}

// The pass-through check: grains that sink into each other past a radius, where the energy check may stay quiet
// (the dashpots take what the deepening potential releases). Here the two soft grains meet at step ~60 and pass.
TEST_CASE("pass-through check: an overlap past the smaller radius is warned about, once, and carried by the state",
          "[gravity][energy]") {
  auto sim = Simulation::create(Scene::from_string(two_grains(0.49682878898616584), "pass"));
  double deepest = 0;
  for (int k = 0; k < 40 && warnings_of(*sim, "contact check") == 0; ++k) {
    sim->step_n(2);
    deepest = std::max(deepest, sim->get("max_overlap_ratio"));
  }
  REQUIRE(warnings_of(*sim, "contact check") == 1);
  CHECK(deepest > 1);
  CHECK_THAT(sim->warnings().back(), Contains("contact check: at t = ") && Contains("times the smaller one's radius") &&
                                         Contains("k* = 10") && Contains("contact.overlap_limit"));
  const std::vector<std::byte> state = sim->save_state();
  run_reading(*sim, 100, 2);
  CHECK(warnings_of(*sim, "contact check") == 1);
  auto restored = Simulation::create(Scene::from_string(two_grains(0.49682878898616584), "pass"));
  restored->restore_state(state);
  run_reading(*restored, 100, 2);
  CHECK(warnings_of(*restored, "contact check") == 0);
  // The stiff grains bounce at overlaps below a tenth of a radius: nothing to warn about (the next case's runs).
}

TEST_CASE("energy check: a stiff dissipative collision under gravity is not warned about", "[gravity][energy]") {
  auto sim = Simulation::create(Scene::from_string(two_grains(0.005), "stiff"));
  CHECK(sim->get("normalised_stiffness") > 5e4);
  CHECK(sim->warnings().empty());   // the contacts hold: the orbit at 2 R_min, far above the step
  const double E0 = total_energy(*sim);
  const auto [lowest, last] = run_reading(*sim, 36000, 10);   // 6 time units: the grains collide, bounce, fall back
  INFO("E0 " << E0 << ", lowest " << lowest << ", last " << last);
  CHECK(last < E0 - 0.01);   // the dashpot took energy
  CHECK(sim->get("max_overlap_ratio") < 0.1);
  CHECK(sim->warnings().empty());
}

TEST_CASE("energy check: the default aggregation scene's first stretch stays quiet", "[gravity][energy]") {
  // 1200 steps (0.21 t_ff), read every 10 steps (the scene's output reads every 200): E wobbles up by some
  // 1e-12 of its scale between reads here, which a check without its margin would warn about.
  auto base = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/aggregation.toml", {"run.threads=1"}));
  CHECK(base->warnings().empty());
  run_reading(*base, 1200, 10);
  CHECK(base->warnings().empty());
}

TEST_CASE("energy check: the default aggregation scene at k* = 10 warns before 0.95 t_ff", "[gravity][energy]") {
  // The sweep's k* = 10, zeta = 0.02 point, read every 8 steps as the sweep's runs are: E rises 1 % of its
  // scale at 0.34 t_ff (step 80) and 29 % at 0.89 t_ff (step 208).
  auto soft = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/aggregation.toml",
                                                  {"run.threads=1", "contact.restitution=0.9390895628611485",
                                                   "contact.duration=0.49682878898616584"}));
  run_reading(*soft, 216, 8);
  CHECK(energy_warnings(*soft) == 1);
}

// A host holding G at 0 leaves a scene of contacts alone: k* is NaN and t_ff means nothing, so the checks' texts
// (which had printed "k* = nan" and blamed the gravitational load) name the contacts' remedy instead.
TEST_CASE("pass-through and energy checks: with G held at 0 the texts blame the contacts, not gravity",
          "[gravity][energy]") {
  // Elastic and at 5 steps per contact, the soft pair passes through and gains energy without any pull.
  std::string scene = two_grains(0.49682878898616584);
  scene.replace(scene.find("restitution = 0.9390895628611485"), 32, "restitution = 1.0");
  auto sim = Simulation::create(Scene::from_string(scene, "no-pull", {"time.steps_per_contact=5"}));
  sim->set("gravity.G", 0.0);
  CHECK(std::isnan(sim->get("normalised_stiffness")));
  double deepest = 0;   // reading an output runs the checks
  for (int k = 0; k < 300; ++k) sim->step_n(1), deepest = std::max(deepest, sim->get("max_overlap_ratio"));
  CHECK(deepest > 1);
  REQUIRE(warnings_of(*sim, "contact check") == 1);
  REQUIRE(warnings_of(*sim, "energy check") == 1);
  for (const std::string& w : sim->warnings()) {
    if (!w.starts_with("contact check") && !w.starts_with("energy check")) continue;
    INFO(w);
    CHECK_THAT(w, !Contains("nan") && !Contains("t_ff") && !Contains("gravit") && Contains("(step "));
    if (w.starts_with("energy")) CHECK_THAT(w, Contains("G is 0 now") && Contains("time.steps_per_contact"));
    else CHECK_THAT(w, Contains("raise the stiffness"));
  }
}
