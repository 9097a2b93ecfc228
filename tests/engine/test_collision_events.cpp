// Collision event log (physics.md section 8): one event per head-on collision with the realised
// restitution as rebound / impact speed; a gravitationally bound, damped pair bounces with decreasing
// speeds and ends adhesive; the log survives save/restore; off by default; logging changes no trajectory.
#include <catch2/catch.hpp>

#include <cmath>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "interactions/normal_calibration.hpp"
#include "io/scene.hpp"
#include "head_on_scene.hpp"
#include "packing_scenes.hpp"
#include "plain_lattice_scene.hpp"

using namespace grains;

namespace {

std::unique_ptr<Simulation> make(const std::string& text) { return Simulation::create(Scene::from_string(text, "collision-log")); }

// Two unit spheres (or disks) approaching head-on at relative speed 1; the surfaces touch at t = gap.
std::string head_on(int dim, double e, double gap) {
  ListedParticles parts = head_on_pair(dim, gap);
  return listed_scene(dim, parts, {e, 1.0, 50}) + "[analysis]\ncollision_log = true\n";
}

}  // namespace

TEST_CASE("collision log: a head-on collision is one rebound event whose speed ratio is the realised restitution",
          "[collisions]") {
  for (int dim : {2, 3})
    for (double e : {0.9, 0.5, 0.1})
      // 0.37 of a step into step 3; and a gap equal to the skin (0.2), where the pair enters the
      // neighbour list at the rebuild of the very step it touches.
      for (double gap : {0.05 + 0.37 / 50, 0.2}) {
      auto sim = make(head_on(dim, e, gap));
      CHECK(sim->get("collision_count") == 0.0);
      CHECK(std::isnan(sim->get("adhesive_collision_fraction")));
      sim->step(0.5);
      CHECK(sim->get("open_collision_count") == 1.0);   // inside the contact (t_c = 1)
      CHECK(sim->get("collision_count") == 0.0);
      sim->step(3.0);
      const auto p = sim->particles();
      const double realised = p.velocity[dim] - p.velocity[0];   // relative speed after, over 1 before
      const auto events = sim->collision_events();
      INFO("dim " << dim << ", e = " << e << ", gap " << gap);
      REQUIRE(events.size() == 1);
      const CollisionEvent& ev = events[0];
      CHECK(ev.i == 0);
      CHECK(ev.j == 1);
      CHECK(ev.adhesive == 0);
      CHECK(ev.impact_speed == Approx(1.0).epsilon(1e-14));
      // No force acts before touching or after separating: the ratio is exactly the realised e.
      CHECK(ev.rebound_speed / ev.impact_speed == Approx(realised).epsilon(1e-12));
      // The exact non-pulling collision (t_c = 1, m* = 1/2), to the 1e-3 that n_c = 50 gives
      // (test_binary_collision.cpp): its restitution, and its surfaces part after the force has ended.
      const auto exact = clamped_collision(damping_ratio(e), std::sqrt(calibrate_linear(e, 1.0, 0.5).k / 0.5));
      CHECK(realised == Approx(exact.restitution).epsilon(1e-3));
      // The gap is linear in time before touching, so the interpolated touching time is exact.
      CHECK(ev.start == Approx(gap).epsilon(1e-12));
      CHECK(ev.end - ev.start == Approx(exact.separation_time).epsilon(1e-3));
      CHECK(sim->get("collision_count") == 1.0);
      CHECK(sim->get("adhesive_collision_count") == 0.0);
      CHECK(sim->get("adhesive_collision_fraction") == 0.0);
      CHECK(sim->get("open_collision_count") == 0.0);
      }
}

TEST_CASE("collision log: a gravitationally bound damped pair bounces with decreasing speeds and ends adhesive",
          "[collisions][gravity]") {
  // Two unit spheres at rest, centres 1.5 apart, G = 1: they fall together at sqrt(4/3) (escape speed at
  // contact 2), rebound at ~e times that, fall back, ... until a rebound cannot leave the overlap.
  const std::string text = R"(
[particles]
layout = "list"
positions = [[0, 0, 0], [1.5, 0, 0]]
diameters = [1.0, 1.0]
masses = [1.0, 1.0]
[box]
periodic = false
[contact]
restitution = 0.3
duration = 0.01
[gravity]
enabled = true
G = 1.0
softening = 0.1
[analysis]
collision_log = true
[run]
threads = 1
)";
  auto sim = make(text);
  sim->step(1.5);
  const auto state = sim->save_state();
  const auto events_at_save = sim->collision_events();
  sim->step(2.5);
  const auto events = sim->collision_events();
  // Four rebounds (impacts 1.153, 0.452, 0.173, 0.062, rebounds at 0.28-0.39 of each; the same with every
  // gravity kernel set), then the fifth impact, at 0.017, ends adhesive: as docs/accuracy.md says.
  REQUIRE(events.size() == 5);
  // Softened potential: impact speed^2 = 2 G M (1/sqrt(1 + eps^2) - 1/sqrt(1.5^2 + eps^2)) with
  // eps = 0.05 and M = 2 (relative motion), the speed one step before touching (dt = 2e-4, a = 2).
  const double eps = 0.05, v0 = std::sqrt(4 * (1 / std::hypot(1.0, eps) - 1 / std::hypot(1.5, eps)));
  CHECK(events[0].impact_speed == Approx(v0).epsilon(1e-3));
  for (std::size_t k = 0; k + 1 < events.size(); ++k) {
    INFO("event " << k << ": impact " << events[k].impact_speed << ", rebound " << events[k].rebound_speed);
    REQUIRE(events[k].adhesive == 0);
    CHECK(events[k].rebound_speed < events[k].impact_speed);
    // A conservative flight between contacts: the pair comes back at the speed it left with, up to
    // the relative acceleration (2 G m / d^2 = 2) times the step, as both speeds are read within a step
    // of the contact.
    CHECK(std::abs(events[k + 1].impact_speed - events[k].rebound_speed) < 2 * 2 * sim->dt());
    CHECK(events[k + 1].start > events[k].end);
  }
  const CollisionEvent& last = events.back();
  CHECK(last.adhesive == 1);
  CHECK(last.rebound_speed == 0.0);
  CHECK(sim->get("adhesive_collision_count") == 1.0);
  CHECK(sim->get("collision_count") == double(events.size()));
  CHECK(sim->get("adhesive_collision_fraction") == Approx(1.0 / double(events.size())));
  CHECK(sim->get("open_collision_count") == 0.0);
  CHECK(sim->get("contacts") == 1.0);   // still touching: the pair rests at its equilibrium overlap
  WARN(fmt::format("bound pair: {} events, impact speeds {:.4g} -> {:.4g}, adhesive after t = {:.4g}", events.size(),
                   events.front().impact_speed, last.impact_speed, last.end));

  // The log is part of the state: restoring and running on gives the same events, bit for bit.
  REQUIRE(events_at_save.size() < events.size());
  sim->restore_state(state);
  const auto restored = sim->collision_events();
  REQUIRE(restored.size() == events_at_save.size());
  sim->step(2.5);
  const auto again = sim->collision_events();
  REQUIRE(again.size() == events.size());
  for (std::size_t k = 0; k < events.size(); ++k) {
    CHECK(again[k].start == events[k].start);
    CHECK(again[k].end == events[k].end);
    CHECK(again[k].impact_speed == events[k].impact_speed);
    CHECK(again[k].rebound_speed == events[k].rebound_speed);
    CHECK(again[k].adhesive == events[k].adhesive);
  }
}

TEST_CASE("collision log: off by default, and refused without contacts", "[collisions]") {
  const std::string plain = plain_lattice_scene();
  auto sim = make(plain);
  CHECK_THROWS(sim->index_of("collision_count"));
  CHECK(sim->collision_events().empty());
  const std::string no_contacts =
      plain_lattice_scene("enabled = false") + "[analysis]\ncollision_log = true\n[time]\ndt = 0.01\n";
  try {
    make(no_contacts);
    FAIL("a collision log without contacts was accepted");
  } catch (const std::exception& e) {
    CHECK_THAT(e.what(), Catch::Contains("analysis.collision_log") && Catch::Contains("contact.enabled"));
  }
}

// The log is an observation: the run it watches is the run without it, bit for bit. It carries its per-pair
// state across list rebuilds by each pair's entry in the previous list. Rows sorted by partner for that would have
// the pair loop, which sums each particle's forces in row order, sum them in another order: a frictional gas of 500
// spheres parts in the last bits within 300 steps (a frictionless 17,576-sphere gas within 300, the aggregation
// scene within 3000 steps).
TEST_CASE("collision log: the trajectory is the one without the log, bit for bit", "[collisions]") {
  for (int threads : {1, 2}) {
    INFO(threads << " thread(s)");
    auto plain = Simulation::create(hot_spheres(threads, false, 0.5));
    auto logged = Simulation::create(hot_spheres(threads, false, 0.5, "[analysis]\ncollision_log = true\n"));
    plain->step_n(300);
    logged->step_n(300);
    REQUIRE(logged->get("collision_count") > 100);
    REQUIRE(plain->get("neighbour_builds") > 2);
    const ParticleView a = plain->particles(), b = logged->particles();
    CHECK(a.position == b.position);
    CHECK(a.velocity == b.velocity);
    CHECK(a.angular_velocity == b.angular_velocity);
  }
}
