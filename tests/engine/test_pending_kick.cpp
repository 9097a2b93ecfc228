// Inside a run of steps the second half kick of each step waits for the next step's first pass
// (core/pending_kick.hpp), and particles whose velocities change between steps (a contact's onset
// correction) are kicked early. None of it may show: a run of n steps must leave the state byte for
// byte as n runs of one step, each of which ends with nothing pending. The scenes start new contacts at
// nearly every step (so the early kicks happen), with a drag (a kick factor other than 1), spins, and
// one and two threads: a hot frictional gas of spheres with a tangential dashpot, and cohesive disks
// with rolling resistance in a fixed cell.
#include <catch2/catch.hpp>

#include "core/simulation.hpp"
#include "packing_scenes.hpp"

using namespace grains;

namespace {

void same_state_either_way(const Scene& scene, long steps, const std::string& what) {
  auto in_one_run = Simulation::create(scene);
  auto step_by_step = Simulation::create(scene);
  in_one_run->step_n(steps);
  for (long k = 0; k < steps; ++k) step_by_step->step_n(1);
  INFO(what << ", " << steps << " steps, contacts at the end: " << in_one_run->get("contacts"));
  REQUIRE(in_one_run->get("contacts") > 0);
  CHECK(in_one_run->save_state() == step_by_step->save_state());
  CHECK(in_one_run->get("kinetic_energy") == step_by_step->get("kinetic_energy"));
}

}  // namespace

TEST_CASE("pending kick: a run of steps leaves the state one-step runs leave, bit for bit", "[integrator]") {
  for (int threads : {1, 2}) {
    INFO(threads << " thread(s)");
    same_state_either_way(hot_spheres(threads, false, 0.5, "[drag]\nrate = 0.3\n"), 600, "frictional gas");
    same_state_either_way(compressed_packing(threads, 0.005, false, "[drag]\nrate = 0.05\n"), 3000, "cohesive disks");
  }
}
