// A cell damping whose relaxation time is far below the particle step: CVODE's non-stiff method resolves it with
// about 1.3 eta / M_c dt steps per particle step (a run at cell.contact_damping = 1e6 is 470 times slower, and a
// failure must name the damping, not cell.mass and the pressure). Warned once past 10;
// a failure names the damping.
#include <catch2/catch.hpp>

#include <string>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "packed_cell_scene.hpp"
#include "warnings_of.hpp"

using namespace grains;
using Catch::Contains;

TEST_CASE("a cell damping stiffer than the step is warned about, costs CVODE steps, and is named when CVODE fails",
          "[barostat][extremes]") {
  const auto cell = [](double ratio) {
    return Simulation::create(Scene::from_string(packed_cell_scene(2, 64, 0.01, fmt::format("damping_ratio = {}", ratio)), "cell"));
  };
  // CVODE steps per particle step over 200 steps
  const auto cost = [](Simulation& s) {
    const double before = s.get("cvode_steps");
    s.step_n(200);
    return (s.get("cvode_steps") - before) / 200;
  };
  auto mild = cell(50), stiff = cell(2000);
  CHECK(warnings_of(*mild, "cell damping") == 0);
  REQUIRE(warnings_of(*stiff, "cell damping") == 1);
  CHECK_THAT(stiff->warnings().back(), Contains("(cell.damping_ratio)") && Contains("lower cell.damping_ratio"));
  const double mild_cost = cost(*mild), stiff_cost = cost(*stiff);
  INFO("CVODE steps per particle step: " << mild_cost << " and " << stiff_cost);
  CHECK(mild_cost < 10);
  CHECK(stiff_cost > 10);   // the warning is no false alarm
  CHECK(warnings_of(*stiff, "cell damping") == 1);   // once
  // Far beyond: CVODE gives up, and the error says why.
  auto hopeless = cell(1e9);
  try {
    hopeless->step_n(10);
    FAIL("CVODE integrated a damping 1e9 times critical");
  } catch (const std::exception& e) {
    CHECK_THAT(e.what(), Contains("the damping makes the equation stiff") && Contains("lower cell.damping_ratio"));
  }
}

// A held cell runs no CVODE (a type-2 sample aggregates in a fixed cell): warned when the host releases it, not before.
TEST_CASE("a stiff cell damping is warned about when the held cell is released, not while it is held",
          "[barostat][extremes]") {
  auto held = Simulation::create(Scene::from_string(packed_cell_scene(2, 64, 0.01, "damping_ratio = 2000\nactive = false"), "held"));
  held->step_n(20);
  CHECK(warnings_of(*held, "cell damping") == 0);
  held->set("cell.active", 1);
  REQUIRE(warnings_of(*held, "cell damping") == 1);
  CHECK_THAT(held->warnings().back(), Contains("lower cell.damping_ratio"));
}
