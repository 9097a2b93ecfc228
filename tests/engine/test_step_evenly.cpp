// step_evenly (a host's step that is not a whole number of dt, fmu/instance.cpp): n equal steps landing exactly
// on t + duration, and a head-on collision taken in steps of 0.685 dt keeps its restitution where whole steps
// beside steps of 0.37 dt did not (their sub-step charges take the next step to be as long).
#include <catch2/catch.hpp>

#include <cmath>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "head_on_scene.hpp"

using namespace grains;

namespace {
// Two unit spheres approaching head-on at relative speed 1, e = 0.5, 50 steps per contact.
std::unique_ptr<Simulation> head_on() {
  return Simulation::create(Scene::from_string(listed_scene(3, head_on_pair(3, 0.05 + 0.37 / 50), {0.5, 1.0, 50}), "evenly"));
}
double restitution_after(Simulation& s, double step, int count, bool evenly) {
  const double before = s.get("kinetic_energy");
  for (int k = 0; k < count; ++k) evenly ? s.step_evenly(step, 2) : s.step(step);
  return std::sqrt(s.get("kinetic_energy") / before);
}
}  // namespace

TEST_CASE("step_evenly: n equal steps land exactly on t + duration", "[integrator]") {
  auto s = head_on();
  const double dt = s->dt();
  s->step_evenly(2.5 * dt, 3);
  CHECK(s->step_count() == 3);
  CHECK(s->time() == 2.5 * dt);
  CHECK_THROWS_WITH(s->step_evenly(2.5 * dt, 2), Catch::Contains("at most dt"));   // 1.25 dt each
  CHECK(s->step_count() == 3);
}

TEST_CASE("step_evenly: equal steps keep a collision's restitution that a short step beside whole ones spoils",
          "[integrator]") {
  auto whole = head_on();
  const double dt = whole->dt(), e_whole = restitution_after(*whole, dt, 300, false);
  auto uneven = head_on();
  const double e_uneven = restitution_after(*uneven, 1.37 * dt, 220, false);   // dt, then 0.37 dt, each step
  auto even = head_on();
  const double e_even = restitution_after(*even, 1.37 * dt, 220, true);      // 0.685 dt, twice
  CHECK(std::abs(e_even / e_whole - 1) < 5e-4);
  CHECK(std::abs(e_uneven / e_whole - 1) > 1e-3);   // whole steps and a shorter one: the restitution spoilt
}
