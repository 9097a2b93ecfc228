// The consolidation programme's rolling quench (protocols/rolling_quench.hpp): the equilibrium a
// quenched stage ends in is one of the paper's law (beta = 0); the switch (the tunable parameter
// rolling.damping_ratio) is part of the saved state; scenes that cannot use it get clear errors.
#include <catch2/catch.hpp>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "protocols/consolidation_programme.hpp"

using namespace grains;

namespace {

// The paper's type-1 law (Table I, mu = 0.5, no rolling resistance) on a few grains, the first stage only.
Scene type1_packing(int count, int seed, double quench, long budget) {
  return Scene::from_string(fmt::format(R"(
[scene]
dimension = 2
[particles]
layout = "random"
count = {}
size_distribution = "uniform"
diameter_min = 0.5
diameter_max = 1.0
density = 1.273239544735163
solid_fraction = 0.36
velocity = "zero"
seed = {}
[box]
periodic = true
[contact]
overlap_limit = 0.5
[adhesion]
enabled = true
force = 1.0
range = 1e-3
stiffness = 1e5
restitution = 0.015
[friction]
coefficient = 0.5
[cell]
enabled = true
pressure = 0.01
contact_damping = 0.0
[programme]
preparation = "type1"
load = false
unload = false
stage_budget = {}
quench_damping = {}
[run]
threads = 1
)", count, seed, budget, quench), "quench");
}

}  // namespace

TEST_CASE("quench: a quenched stage ends in an equilibrium of the paper's law (beta = 0)", "[quench][programme]") {
  // 12 grains (seed 3) settle within 160,000 steps and are quenched from about step 157,500.
  auto scene = type1_packing(12, 3, 0.003, 200000);
  auto s = Simulation::create(scene);
  const auto stages = run_programme(*s, ProgrammeSettings::from_scene(scene));
  REQUIRE(stages.size() == 1);
  REQUIRE(stages[0].reached);
  REQUIRE(stages[0].quench_start > 0);   // the stage was quenched
  CHECK(stages[0].quench_start < stages[0].steps);
  // Left on the paper's law, judged on forces evaluated without the dashpot...
  CHECK(s->get("rolling.damping_ratio") == 0.0);
  CHECK(s->get("equilibrium") == 1.0);
  // ...and nothing the dashpot held is set off without it. A state held by the dashpot (spins creeping
  // against it, as with beta = 1) jumps to force ratios of 100-600 within 100 steps of switching it off;
  // this one stays near its threshold (single checks of it are a residual slow oscillation's, which
  // wanders about 1-2 here).
  for (int k = 0; k < 20; ++k) {
    s->step_n(100);
    INFO("step " << (k + 1) * 100 << " after the stage: force ratio " << s->get("equilibrium_force") << ", torque ratio "
                 << s->get("equilibrium_torque"));
    CHECK(s->get("equilibrium_force") < 3);
    CHECK(s->get("equilibrium_torque") < 3);
    CHECK(s->get("equilibrium_kinetic") < 1);
  }
}

TEST_CASE("quench: the rolling dashpot switch is part of the saved state", "[quench][seam]") {
  auto scene = type1_packing(40, 1, 0.003, 1000);
  auto s = Simulation::create(scene);
  const auto& vars = s->variables();
  const auto& beta = vars[s->index_of("rolling.damping_ratio")];
  CHECK(beta.variability == Variability::tunable);
  CHECK(s->get("rolling.damping_ratio") == 0.0);   // the scene's value
  s->step_n(60000);   // compacting: some grains in contact, spinning
  REQUIRE(s->get("contacts") > 5);
  s->set("rolling.damping_ratio", 0.5);   // switched on
  const auto saved = s->save_state();
  s->step_n(500);
  const auto reference = s->particles();

  auto fresh = Simulation::create(scene);   // built with beta = 0
  fresh->restore_state(saved);
  CHECK(fresh->get("rolling.damping_ratio") == 0.5);
  fresh->step_n(500);
  CHECK(fresh->particles().position == reference.position);
  CHECK(fresh->particles().angular_velocity == reference.angular_velocity);
  // The dashpot acted: the same state continued without it differs.
  fresh->restore_state(saved);
  fresh->set("rolling.damping_ratio", 0.0);
  fresh->step_n(500);
  CHECK(fresh->particles().angular_velocity != reference.angular_velocity);
}

TEST_CASE("quench: bad values and conflicting keys are named", "[quench][programme]") {
  auto scene = type1_packing(40, 1, 0.003, 1000);
  auto s = Simulation::create(scene);
  CHECK_THROWS_WITH(s->set("rolling.damping_ratio", 2.0),
                    Catch::Contains("rolling.damping_ratio") && Catch::Contains("2") && Catch::Contains("[0, 1]"));
  CHECK(s->get("rolling.damping_ratio") == 0.0);
  // A dashpot kept on throughout and the programme's switch cannot both hold.
  auto conflicting = type1_packing(40, 1, 0.003, 1000);
  conflicting.set_value("rolling.damping_ratio", "0.01");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(conflicting),
                    Catch::Contains("rolling.damping_ratio") && Catch::Contains("programme.quench_damping"));
  conflicting.set_value("programme.quench_damping", "0.0");   // no switch: the scene's dashpot stays on
  CHECK(ProgrammeSettings::from_scene(conflicting).quench.damping == 0.0);
}
