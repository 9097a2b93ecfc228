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
#include "packing_scenes.hpp"

using namespace grains;

namespace {

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
