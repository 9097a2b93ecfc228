// The batched (AVX-512) evaluation of steady contacts against the portable pair loop, on 1 and 2 threads:
// the whole saved state (positions, velocities, springs, stamps, cell) is the same byte for byte, and the
// contact counters agree.
// - Cohesive disks (interactions/cohesive_contacts_avx512.hpp): a loose packing with friction and rolling
//   resistance (rolling dashpot on), in a fixed cell and compressed in a pressure-controlled one. It gains
//   contacts, slides and rolls on the way, so steady contacts, first steps, distant bonds, the parting
//   charge and both Coulomb caps all occur.
// - Spheres (interactions/linear_contacts_avx512.hpp): a dense hot gas, fixed and compressed (so the
//   release charge, clamped overlaps and the affine flow occur), frictionless and with Coulomb friction
//   (mu = 0.1: most contacts slide; mu = 0.5 with k_t = 2/7 k_n and c_t = c_n / 2 as in the gas-friction scene).
#include <catch2/catch.hpp>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "interactions/pair_filter.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {

Scene compressed_packing(int threads, double rolling, bool affine) {
  return Scene::from_string(fmt::format(R"(
[scene]
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
coefficient = {}
damping_ratio = 0.01
[cell]
enabled = true
active = {}
pressure = 0.05
[run]
threads = {}
)", rolling, affine, threads), "batched");
}

struct Outcome {
  std::vector<std::byte> state;
  double contacts, clamped;
};

Outcome run(const Scene& scene, bool portable, long steps) {
  pair_filter::prefer_portable(portable);
  auto s = Simulation::create(scene);
  s->step_n(steps);
  pair_filter::prefer_portable(false);
  return {s->save_state(), s->get("contacts"), s->get("clamped_contacts_total")};
}

}  // namespace

TEST_CASE("batched contacts, cohesive disks: bit-identical to the portable pair loop", "[contacts][batched]") {
  pair_filter::prefer_portable(false);
  if (!pair_filter::avx512()) {
    WARN("no AVX-512 here: only the portable pair loop runs");
    return;
  }
  for (int threads : {1, 2})
    for (double rolling : {0.0, 0.005})
      for (bool affine : {true, false}) {
        const Scene scene = compressed_packing(threads, rolling, affine);
        INFO("threads " << threads << ", rolling " << rolling << ", deforming cell " << affine);
        const Outcome batched = run(scene, false, 30000), portable = run(scene, true, 30000);
        CHECK(batched.contacts > 100);   // steady contacts are most of the work
        CHECK(batched.contacts == portable.contacts);
        CHECK(batched.clamped == portable.clamped);
        CHECK(batched.state.size() == portable.state.size());
        CHECK(batched.state == portable.state);
      }
}

namespace {

Scene hot_spheres(int threads, bool cell, double mu) {
  return Scene::from_string(fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "random"
count = 500
size_distribution = "uniform"
diameter_min = 0.6
diameter_max = 1.0
solid_fraction = 0.3
velocity = "gaussian"
kinetic_energy = 1.5
seed = 9
[box]
periodic = true
[contact]
restitution = 0.6
duration = 0.05
overlap_limit = 0.05
[friction]
coefficient = {}
stiffness_ratio = 0.2857142857142857
damping_ratio = 0.5
[cell]
enabled = {}
force_unit = 0
pressure = 1e-3
[run]
threads = {}
)", mu, cell, threads), "batched-linear");
}

}  // namespace

TEST_CASE("batched contacts, spheres with and without friction: bit-identical to the portable pair loop", "[contacts][batched]") {
  pair_filter::prefer_portable(false);
  if (!pair_filter::avx512()) {
    WARN("no AVX-512 here: only the portable pair loop runs");
    return;
  }
  for (int threads : {1, 2})
    for (bool cell : {false, true})
      for (double mu : {0.0, 0.1, 0.5}) {
        const Scene scene = hot_spheres(threads, cell, mu);
        INFO("threads " << threads << ", pressure-controlled cell " << cell << ", mu " << mu);
        const Outcome batched = run(scene, false, 4000), portable = run(scene, true, 4000);
        CHECK(batched.contacts > 30);   // friction cools the gas: fewer contacts at the end
        CHECK(batched.clamped > 0);   // overlaps beyond the limit happen too
        CHECK(batched.contacts == portable.contacts);
        CHECK(batched.clamped == portable.clamped);
        CHECK(batched.state == portable.state);
      }
}
