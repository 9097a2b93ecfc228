// A continuous ramp of the barostat's target pressure (cell.pressure_final, cell.ramp_duration): the target
// follows the geometric law with CVODE's history kept (restarted only on its schedule), the packing ends at the final pressure, a host's
// cell.pressure takes over, a saved state continues the ramp exactly, and bad ramps are refused.
#include <catch2/catch.hpp>

#include <cmath>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "packed_cell_scene.hpp"
#include "protocols/consolidation_programme.hpp"

using namespace grains;

namespace {
// 100 cohesionless disks from P / K_N = 1e-3 to 4e-3 over 60 time units (60,000 steps of dt = 1e-3).
std::string ramp_scene(const std::string& extra = "") {
  return packed_cell_scene(2, 100, 1e-3, "pressure_final = 4e-3\nramp_duration = 60.0\n" + extra);
}
}  // namespace

TEST_CASE("pressure ramp: the target follows P0 (P1/P0)^(t/T), the cell follows it, CVODE restarts only on schedule",
          "[barostat][ramp]") {
  auto s = Simulation::create(Scene::from_string(ramp_scene(), "ramp"));
  const double dt = s->dt();
  REQUIRE(dt == Approx(1e-3).epsilon(1e-12));
  double worst = 0;
  for (int k = 0; k < 12; ++k) {
    s->step_n(5000);
    // The target of the last step: the ramp at that step's start, frozen over it like the stress.
    const double t = s->time() - dt;
    worst = std::max(worst, std::abs(s->get("pressure_target") / (1e-3 * std::pow(4.0, t / 60.0)) - 1));
    CHECK(s->get("cell.pressure") == s->get("pressure_target"));
  }
  CHECK(worst < 1e-14);   // measured 0: the same expression
  s->step_n(100);   // past the end: held at the final value exactly
  CHECK(s->get("pressure_target") == 4e-3);
  // The start and the scheduled restarts only, one every 500 advances (what a saved state carries): a ramp is
  // no new target.
  CHECK(s->get("cvode_reinitialisations") == 1 + (s->step_count() - 1) / 500);
  // A slow ramp over a jammed packing: the stress has followed it (3.2e-4 behind), and it settles at the
  // final pressure.
  CHECK(std::abs(s->get("pressure_reduced") / 4e-3 - 1) < 1e-3);
  long steps = 0;
  while (s->get("equilibrium") != 1.0 && steps < 300000) s->step_n(200), steps += 200;
  REQUIRE(s->get("equilibrium") == 1.0);
  CHECK(std::abs(s->get("pressure_reduced") / 4e-3 - 1) < 1e-5);
}

TEST_CASE("pressure ramp: a host setting cell.pressure takes over from the ramp", "[barostat][ramp]") {
  auto s = Simulation::create(Scene::from_string(ramp_scene(), "ramp"));
  s->step_n(20000);
  s->set("cell.pressure", 1.5e-3);
  s->step_n(20000);
  CHECK(s->get("pressure_target") == 1.5e-3);
  CHECK(s->get("cell.pressure") == 1.5e-3);
}

TEST_CASE("pressure ramp: a state saved mid-ramp continues it bit-identically, and a host's takeover too",
          "[barostat][ramp]") {
  for (const bool taken_over : {false, true}) {
    INFO("host took over: " << taken_over);
    auto s = Simulation::create(Scene::from_string(ramp_scene(), "ramp"));
    s->step_n(20000);
    if (taken_over) s->set("cell.pressure", 1.5e-3);
    const auto saved = s->save_state();
    s->step_n(10000);
    const auto reference = s->save_state();
    auto other = Simulation::create(Scene::from_string(ramp_scene(), "ramp"));
    other->restore_state(saved);
    other->step_n(10000);
    CHECK(other->save_state() == reference);
    CHECK(other->get("pressure_target") == (taken_over ? 1.5e-3 : s->get("pressure_target")));
  }
}

TEST_CASE("pressure ramp: incomplete or conflicting ramps get errors naming the field", "[barostat][ramp]") {
  auto fails = [](const std::string& text, const std::string& field) {
    INFO(field);
    CHECK_THROWS_WITH(Simulation::create(Scene::from_string(text, "bad")), Catch::Contains(field));
  };
  fails(packed_cell_scene(2, 100, 1e-3, "pressure_final = 4e-3"), "cell.ramp_duration");
  fails(packed_cell_scene(2, 100, 1e-3, "ramp_duration = 10.0"), "cell.pressure_final");
  fails(packed_cell_scene(2, 100, 1e-3, "pressure_final = 0\nramp_duration = 10.0"), "cell.pressure_final");
  fails(packed_cell_scene(2, 100, 1e-3, "pressure_final = 4e-3\nramp_duration = 0"), "cell.ramp_duration");
  const auto programme = Scene::from_string(ramp_scene("[programme]\ntop_pressure = 4e-3"), "bad");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(programme), Catch::Contains("cell.pressure_final"));
}
