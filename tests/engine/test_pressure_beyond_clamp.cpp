// A target pressure whose force on a grain, P a^(D-1), reaches the clamped contact's largest elastic force
// K_N f_max R_min cannot be held: the packing collapses into overlaps past the clamp (64 disks driven to
// twice that pressure reached a solid fraction of 1.13 with no warning). The scene's targets and a host's
// or a programme's later ones are warned about, once.
#include <catch2/catch.hpp>

#include <algorithm>
#include <string>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "packed_cell_scene.hpp"
#include "warnings_of.hpp"

using namespace grains;
using Catch::Contains;

namespace {
long clamp_warnings(const Simulation& s) { return warnings_of(s, "clamped contact gives"); }
}  // namespace

// Cohesionless, so P* = P a^(D-2) / k_n and P a^(D-1) = P* k_n a; the cap k_n 0.1 R_min with R_min near a / 4
// puts the bound near P* = 0.025 (a little above: the smallest drawn radius exceeds a / 4).
TEST_CASE("a target pressure beyond what the clamped contacts carry is warned about, once", "[barostat][extremes]") {
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    auto held = Simulation::create(Scene::from_string(packed_cell_scene(dim, 64, 0.02), "held"));
    CHECK(clamp_warnings(*held) == 0);
    auto crushed = Simulation::create(Scene::from_string(packed_cell_scene(dim, 64, 0.05), "crushed"));
    REQUIRE(clamp_warnings(*crushed) == 1);
    CHECK_THAT(crushed->warnings().back(), Contains("cell.pressure = 0.05 asks each contact for about P a^(D-1)") &&
                                               Contains("keep P* below 0.02"));
    auto ramped = Simulation::create(Scene::from_string(
        packed_cell_scene(dim, 64, 0.02, "pressure_final = 0.1\nramp_duration = 1"), "ramped"));
    REQUIRE(clamp_warnings(*ramped) == 1);
    CHECK_THAT(ramped->warnings().back(), Contains("cell.pressure_final = 0.1"));
    // A host (or the consolidation programme) raising the target: warned at the first value past the bound only.
    held->set(held->index_of("cell.pressure"), 0.021);
    CHECK(clamp_warnings(*held) == 0);
    held->set(held->index_of("cell.pressure"), 0.06);
    held->set(held->index_of("cell.pressure"), 0.1);
    CHECK(clamp_warnings(*held) == 1);
    CHECK_THAT(held->warnings().back(), Contains("cell.pressure = 0.06"));
  }
}

// A restored state knows whether it was warned: restoring it neither warns again (a resumed programme counts the
// restored simulation's warnings as already in its file, so one raised there was lost) nor forgets the warning.
TEST_CASE("a saved state carries whether the clamp warning was given", "[barostat][extremes][state]") {
  auto warned = Simulation::create(Scene::from_string(packed_cell_scene(2, 64, 0.02), "held"));
  warned->set(warned->index_of("cell.pressure"), 0.06);
  REQUIRE(clamp_warnings(*warned) == 1);
  const auto state = warned->save_state();
  auto restored = Simulation::create(Scene::from_string(packed_cell_scene(2, 64, 0.02), "held"));
  restored->restore_state(state);
  CHECK(clamp_warnings(*restored) == 0);                      // not raised by the restore itself
  restored->set(restored->index_of("cell.pressure"), 0.1);
  CHECK(clamp_warnings(*restored) == 0);                      // and given once per trajectory
}
