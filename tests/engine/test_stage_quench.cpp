// The consolidation programme's quench of settled stages (protocols/stage_quench.hpp): the equilibrium
// a quenched stage ends in is one of the paper's law (no drag, beta = 0); the switches (the tunable
// parameters drag.rate and rolling.damping_ratio) are part of the saved state; scenes that cannot use
// them get clear errors.
#include <catch2/catch.hpp>

#include <algorithm>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "protocols/consolidation_programme.hpp"
#include "type1_packing_scene.hpp"

using namespace grains;

TEST_CASE("quench: a quenched stage ends in an equilibrium of the paper's law (no drag)", "[quench][programme]") {
  // 12 grains (seed 3), the default quench (the drag, gamma T = 1, confirmed over 5 checks).
  auto scene = type1_packing(12, 3, 1.0, 0.0, 200000);
  auto s = Simulation::create(scene);
  const auto stages = run_programme(*s, ProgrammeSettings::from_scene(scene));
  REQUIRE(stages.size() == 1);
  REQUIRE(stages[0].reached);
  REQUIRE(stages[0].quench_start > 0);   // the stage was quenched
  CHECK(stages[0].quench_start < stages[0].steps);
  // Left on the paper's law, judged on forces evaluated without the drag...
  CHECK(s->get("drag.rate") == 0.0);
  CHECK(s->get("equilibrium") == 1.0);
  // ...and nothing the drag held is set off without it. A state held by a damper (grains creeping
  // against it, as with a rolling dashpot of beta = 1) jumps to force ratios of 100-600 within 100
  // steps of switching it off. Ended after single checks, this stage read 3-4 times the threshold 200
  // steps later (a contact-scale mode swinging back); confirmed over 5 checks it stays below 0.7.
  for (int k = 0; k < 20; ++k) {
    s->step_n(100);
    INFO("step " << (k + 1) * 100 << " after the stage: force ratio " << s->get("equilibrium_force") << ", torque ratio "
                 << s->get("equilibrium_torque"));
    CHECK(s->get("equilibrium_force") < 1.5);
    CHECK(s->get("equilibrium_torque") < 1.5);
    CHECK(s->get("equilibrium_kinetic") < 1);
  }
}

TEST_CASE("quench: the drag switch is part of the saved state", "[quench][seam]") {
  auto scene = type1_packing(40, 1, 1.0, 0.0, 1000);
  auto s = Simulation::create(scene);
  const auto& drag = s->variables()[s->index_of("drag.rate")];
  CHECK(drag.variability == Variability::tunable);
  CHECK(s->get("drag.rate") == 0.0);   // the scene's value
  s->step_n(60000);                    // compacting: grains moving
  s->set("drag.rate", 2.0);            // switched on
  const auto saved = s->save_state();
  s->step_n(500);
  const auto reference = s->particles();

  auto fresh = Simulation::create(scene);   // built without drag
  fresh->restore_state(saved);
  CHECK(fresh->get("drag.rate") == 2.0);
  fresh->step_n(500);
  CHECK(fresh->particles().velocity == reference.velocity);
  CHECK(fresh->particles().angular_velocity == reference.angular_velocity);
  // The drag acted: the same state continued without it moves faster.
  fresh->restore_state(saved);
  fresh->set("drag.rate", 0.0);
  fresh->step_n(500);
  CHECK(fresh->get("translational_energy") > s->get("translational_energy"));
}

TEST_CASE("quench: the rolling dashpot switch is part of the saved state", "[quench][seam]") {
  auto scene = type1_packing(40, 1, 1.0, 0.003, 1000);
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
  auto scene = type1_packing(40, 1, 1.0, 0.003, 1000);
  auto s = Simulation::create(scene);
  CHECK_THROWS_WITH(s->set("rolling.damping_ratio", 2.0),
                    Catch::Contains("rolling.damping_ratio") && Catch::Contains("2") && Catch::Contains("[0, 1]"));
  CHECK(s->get("rolling.damping_ratio") == 0.0);
  CHECK_THROWS_WITH(s->set("drag.rate", -1.0), Catch::Contains("drag.rate") && Catch::Contains("-1"));
  CHECK(s->get("drag.rate") == 0.0);
  // A drag kept on throughout and the programme's switch cannot both hold.
  auto dragging = type1_packing(40, 1, 1.0, 0.0, 1000);
  dragging.set_value("drag.rate", "0.5");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(dragging),
                    Catch::Contains("drag.rate") && Catch::Contains("programme.quench_drag"));
  dragging.set_value("programme.quench_drag", "0.0");
  CHECK(ProgrammeSettings::from_scene(dragging).quench.drag == 0.0);
  // A dashpot kept on throughout and the programme's switch cannot both hold.
  auto conflicting = type1_packing(40, 1, 1.0, 0.003, 1000);
  conflicting.set_value("rolling.damping_ratio", "0.01");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(conflicting),
                    Catch::Contains("rolling.damping_ratio") && Catch::Contains("programme.quench_damping"));
  conflicting.set_value("programme.quench_damping", "0.0");   // no switch: the scene's dashpot stays on
  CHECK(ProgrammeSettings::from_scene(conflicting).quench.damping == 0.0);
}

namespace {

// A stand-in Simulation whose equilibrium readings the test scripts, to drive StageQuench alone (not in
// equilibrium unless the test says so).
class ScriptedReadings final : public Simulation {
 public:
  double equilibrium = 0, kinetic = 1, stress = 1, phi = 0.4, drag = 0, beta = 0;
  static constexpr double inertial_time = 4;
  void step(double) override {}
  void step_n(long) override {}
  void step_evenly(double, long) override {}
  double time() const override { return 0; }
  long step_count() const override { return 0; }
  double dt() const override { return 1; }
  int dimension() const override { return 2; }
  int threads() const override { return 1; }
  std::size_t particle_count() const override { return 0; }
  const std::vector<VariableInfo>& variables() const override { return variables_; }
  double get(std::size_t k) const override {
    const double values[] = {equilibrium, kinetic, stress, phi, inertial_time, drag, beta};
    return values[k];
  }
  void set(std::size_t k, double value) override {
    if (k == 5) drag = value;
    if (k == 6) beta = value;
  }
  std::vector<std::byte> save_state() const override { return {}; }
  void restore_state(std::span<const std::byte>) override {}
  ParticleView particles() const override { return {}; }
  BoxView box() const override { return {}; }
  const std::vector<std::string>& warnings() const override { return warnings_; }

 private:
  std::vector<VariableInfo> variables_ = {
      {"equilibrium", "", Causality::output, Variability::continuous, ""},
      {"equilibrium_kinetic", "", Causality::output, Variability::continuous, ""},
      {"equilibrium_stress", "", Causality::output, Variability::continuous, ""},
      {"solid_fraction", "", Causality::output, Variability::continuous, ""},
      {"inertial_time", "", Causality::output, Variability::continuous, ""},
      {"drag.rate", "", Causality::parameter, Variability::tunable, ""},
      {"rolling.damping_ratio", "", Causality::parameter, Variability::tunable, ""}};
  std::vector<std::string> warnings_;
};

}  // namespace

TEST_CASE("quench: a packing still compacting at its target pressure is not quenched", "[quench]") {
  ScriptedReadings s;
  QuenchSettings q;   // drag T 1, no rolling dashpot, ratios below 100 for 20 checks, solid fraction steady to 1e-5
  StageQuench quench(s, q);
  // Kinetic and stress ratios small, but the packing collapses: 2e-5 relative per check.
  for (int check = 0; check < 200; ++check) {
    s.phi *= 1 + 2e-5;
    quench.in_equilibrium(100 * check);
  }
  CHECK(s.drag == 0.0);
  CHECK(quench.start() == -1);
  // The collapse stops (changes far below 1e-5 over the run): quenched after 20 steady checks.
  int switched_at = -1;
  for (int check = 200; check < 260 && switched_at < 0; ++check) {
    s.phi *= 1 + 1e-8;
    quench.in_equilibrium(100 * check);
    if (s.drag > 0) switched_at = check;
  }
  CHECK(switched_at == 218);   // the run starts at the last moving check (199): 20 checks in, at 218, it switches
  CHECK(s.drag == q.drag / ScriptedReadings::inertial_time);   // gamma = (gamma T) / T
  CHECK(s.beta == 0.0);                                         // the rolling dashpot is not used by default
  quench.end();
  CHECK(s.drag == 0.0);
  // With the compaction test off (1: any change passes), the ratios alone decide; the rolling dashpot,
  // when asked for, is switched with the drag.
  ScriptedReadings t;
  q.settle_compaction = 1;
  q.damping = 0.003;
  StageQuench ratios_only(t, q);
  for (int check = 0; check < 20; ++check) {
    t.phi *= 1 + 2e-5;
    ratios_only.in_equilibrium(100 * check);
  }
  CHECK(t.drag == q.drag / ScriptedReadings::inertial_time);
  CHECK(t.beta == q.damping);
}

TEST_CASE("quench: a background drag lies beneath the quench and leaves with the stage", "[quench]") {
  constexpr double T = ScriptedReadings::inertial_time;
  ScriptedReadings s;
  QuenchSettings q;   // quench drag gamma T = 1
  q.background = 0.05;
  StageQuench quench(s, q);
  CHECK(s.drag == 0.05 / T);   // from the stage's first step
  for (int check = 0; check < 20; ++check) quench.in_equilibrium(100 * check);   // settled: quenched at the 20th
  CHECK(s.drag == 1.0 / T);
  s.equilibrium = 1;
  CHECK_FALSE(quench.in_equilibrium(2000));   // the criteria hold: the quench goes, the background stays
  CHECK(s.drag == 0.05 / T);
  for (int check = 1; check < 5; ++check) CHECK_FALSE(quench.in_equilibrium(2000 + 100 * check));
  CHECK(quench.in_equilibrium(2500));   // confirmed over 5 checks beneath the background drag
  quench.end();
  CHECK(s.drag == 0.0);
  // Without a quench the background drag alone stays throughout the stage.
  ScriptedReadings t;
  QuenchSettings none;
  none.drag = 0, none.background = 0.05;
  StageQuench background_only(t, none);
  for (int check = 0; check < 40; ++check) background_only.in_equilibrium(100 * check);
  CHECK(t.drag == 0.05 / T);
  background_only.end();
  CHECK(t.drag == 0.0);
}

TEST_CASE("quench: the programme's background drag acts in its stages under pressure only", "[quench][programme]") {
  auto scene = type1_packing(12, 3, 1.0, 0.0, 200000);
  scene.set_value("programme.background_drag", "0.05");
  auto s = Simulation::create(scene);
  double least = 1e300;
  const auto stages = run_programme(*s, ProgrammeSettings::from_scene(scene), {},
                                    [&](const StageRecord&, long, const StageProgress&) {
                                      least = std::min(least, s->get("drag.rate"));
                                      return false;
                                    });
  REQUIRE(stages.size() == 1);
  CHECK(stages[0].reached);
  CHECK(least == Approx(0.05 / s->get("inertial_time")).epsilon(1e-12));   // never below it in the stage
  CHECK(s->get("drag.rate") == 0.0);                                       // gone with the programme
  // A drag kept on throughout cannot also be the programme's background.
  auto dragging = type1_packing(12, 3, 0.0, 0.0, 1000);
  dragging.set_value("drag.rate", "0.5");
  dragging.set_value("programme.background_drag", "0.05");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(dragging),
                    Catch::Contains("drag.rate") && Catch::Contains("programme.background_drag"));
}
