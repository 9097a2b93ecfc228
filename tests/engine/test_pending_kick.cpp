// Inside a run of steps the second half kick of each step waits for the next step's first pass
// (core/pending_kick.hpp), and particles whose velocities change between steps (a contact's onset
// correction) are kicked early. None of it may show: a run of n steps must leave the state byte for
// byte as n runs of one step, each of which ends with nothing pending. The scenes below start new
// contacts at nearly every step (so the early kicks happen), with a drag (a kick factor other than 1),
// spins, and one and two threads.
#include <catch2/catch.hpp>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {

// A hot, dense gas of spheres with Coulomb friction and a tangential dashpot.
Scene frictional_gas(int threads) {
  return Scene::from_string(fmt::format(R"(
[scene]
name = "frictional gas"
dimension = 3
[particles]
layout = "random"
count = 400
diameter = 1.0
mass = 1.0
solid_fraction = 0.3
velocity = "gaussian"
kinetic_energy = 1.5
seed = 7
[box]
periodic = true
[contact]
restitution = 0.9
duration = 0.05
[friction]
coefficient = 0.5
stiffness_ratio = 0.2857142857142857
damping_ratio = 0.5
[drag]
rate = 0.3
[time]
dt = 0.001
[run]
threads = {}
)", threads), "frictional gas");
}

// Cohesive disks (adhesion, friction, rolling resistance) in a fixed periodic cell.
Scene cohesive_disks(int threads) {
  return Scene::from_string(fmt::format(R"(
[scene]
name = "cohesive disks"
dimension = 2
[particles]
layout = "random"
count = 300
size_distribution = "uniform"
diameter_min = 0.5
diameter_max = 1.0
density = 1.273239544735163
solid_fraction = 0.36
velocity = "gaussian"
kinetic_energy = 0.02
seed = 5
[box]
periodic = true
[contact]
overlap_limit = 0.5
[adhesion]
enabled = true
[friction]
coefficient = 0.5
[rolling]
coefficient = 0.005
damping_ratio = 0.01
[drag]
rate = 0.05
[run]
threads = {}
)", threads), "cohesive disks");
}

void same_state_either_way(const Scene& scene, long steps) {
  auto in_one_run = Simulation::create(scene);
  auto step_by_step = Simulation::create(scene);
  in_one_run->step_n(steps);
  for (long k = 0; k < steps; ++k) step_by_step->step_n(1);
  INFO(scene.text("scene.name") << ", " << steps << " steps, contacts at the end: " << in_one_run->get("contacts"));
  REQUIRE(in_one_run->get("contacts") > 0);
  CHECK(in_one_run->save_state() == step_by_step->save_state());
  CHECK(in_one_run->get("kinetic_energy") == step_by_step->get("kinetic_energy"));
}

}  // namespace

TEST_CASE("pending kick: a run of steps leaves the state one-step runs leave, bit for bit", "[integrator]") {
  for (int threads : {1, 2}) {
    same_state_either_way(frictional_gas(threads), 600);
    same_state_either_way(cohesive_disks(threads), 3000);
  }
}
