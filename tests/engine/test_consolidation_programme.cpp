// The consolidation programme: its pressure ladder, and a short loading / unloading run in which
// every stage reaches equilibrium, or is reported when its budget is too small.
#include <catch2/catch.hpp>

#include <cmath>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "analysis/bonded_clusters.hpp"
#include "packed_cell_scene.hpp"
#include "protocols/consolidation_programme.hpp"
#include "type1_packing_scene.hpp"

using namespace grains;

TEST_CASE("programme: the paper's ladder, 0.01 to 13.33 by 10^(1/8), unloading back to 0.01", "[programme]") {
  ProgrammeSettings p;   // defaults: 8 stages per decade up to 13.33, unloading 2 per decade
  const auto ladder = programme_pressures(p);
  std::vector<double> loading, unloading;
  for (const auto& [phase, P] : ladder) (phase == "loading" ? loading : unloading).push_back(P);
  REQUIRE(loading.size() == 25);   // 0.01 * 10^(25/8) = 13.335
  CHECK(loading.front() == Approx(0.01 * std::pow(10.0, 0.125)).epsilon(1e-14));
  CHECK(loading.back() == Approx(13.335).epsilon(1e-4));
  for (std::size_t k = 1; k < loading.size(); ++k) CHECK(loading[k] / loading[k - 1] == Approx(1.3335214).epsilon(1e-7));
  REQUIRE(unloading.size() == 7);   // 4.2, 1.3, 0.42, 0.13, 0.042, 0.013, then 0.01
  CHECK(unloading.front() == Approx(loading.back() / std::sqrt(10.0)).epsilon(1e-14));
  CHECK(unloading.back() == 0.01);
  p.unload = false;
  CHECK(programme_pressures(p).size() == 25);
}

namespace {
// The barostat tests' 2D packing of 100 grains, through a short programme up to 4e-3.
std::string small_programme(long stage_budget) {
  return packed_cell_scene(2, 100, 1e-3, fmt::format(R"(
[programme]
top_pressure = 4e-3
stages_per_decade = 2
stage_budget = {})", stage_budget));
}
double value(const StageRecord& r, const std::string& name) {
  for (const auto& [n, v] : r.values)
    if (n == name) return v;
  FAIL("no value " << name);
  return 0;
}
}  // namespace

TEST_CASE("programme: loading and unloading, every stage in equilibrium at its pressure", "[programme]") {
  auto scene = Scene::from_string(small_programme(400000), "programme");
  auto s = Simulation::create(scene);
  int calls = 0;
  const auto stages = run_programme(*s, ProgrammeSettings::from_scene(scene), [&](const StageRecord&) { ++calls; });
  // Prepared at 1e-3, loading 3.16e-3, unloading 1e-3.
  REQUIRE(stages.size() == 3);
  CHECK(calls == 3);
  CHECK(stages[1].phase == "loading");
  CHECK(stages[2].phase == "unloading");
  for (const auto& r : stages) {
    INFO("stage " << r.index << " at " << r.target);
    CHECK(r.reached);
    CHECK(std::abs(value(r, "pressure_reduced") / r.target - 1) < 1e-5);
  }
  CHECK(value(stages[1], "solid_fraction") > value(stages[0], "solid_fraction"));
  // Unloading keeps most of the compaction (irreversible: Phi does not fall back below the start).
  CHECK(value(stages[2], "solid_fraction") >= value(stages[0], "solid_fraction") - 1e-3);
}

TEST_CASE("programme: a stage that cannot reach equilibrium within its budget is reported", "[programme]") {
  auto scene = Scene::from_string(small_programme(500), "programme");
  auto s = Simulation::create(scene);
  const auto stages = run_programme(*s, ProgrammeSettings::from_scene(scene));
  REQUIRE(stages.size() == 3);   // the programme goes on, every stage recorded
  for (const auto& r : stages) {
    CHECK_FALSE(r.reached);
    CHECK(r.steps == 500);
  }
}

TEST_CASE("programme: scenes it cannot run get errors naming the field", "[programme]") {
  auto no_cell = Scene::from_string(R"(
[scene]
dimension = 2
[particles]
count = 16
solid_fraction = 0.3
[contact]
duration = 0.05
[programme]
preparation = "type1"
)", "bad");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(no_cell), Catch::Contains("cell.enabled"));
  auto type2 = Scene::from_string(small_programme(10) + "\n", "bad", {"programme.preparation=type2"});
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(type2), Catch::Contains("programme.preparation") && Catch::Contains("adhesion"));
  // A type-2 sample whose adhesion gives no force scale cannot relax at P* = 0: refused up front, naming the key
  // (it failed at the P* = 0 stage, naming cell.pressure, after the output was written).
  auto forceless = type1_packing(12, 3, 1.0, 0.0, 1000);
  forceless.set_value("programme.preparation", "\"type2\"");
  forceless.set_value("adhesion.force", "0");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(forceless), Catch::Contains("adhesion.force") && Catch::Contains("P* = 0"));
  forceless.set_value("cell.force_unit", "0");
  forceless.set_value("adhesion.force", "1");
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(forceless), Catch::Contains("cell.force_unit"));
  auto low_top = Scene::from_string(small_programme(10), "bad", {"programme.top_pressure=1e-4"});
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(low_top), Catch::Contains("programme.top_pressure"));
  // A loading ladder from P* = 0 would plan stages until memory ran out; a top pressure past what a stage can set
  // would fail at that stage, after the others. Both are refused up front.
  auto from_zero = Scene::from_string(small_programme(10000), "bad", {"cell.pressure=0", "cell.force_unit=1"});
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(from_zero), Catch::Contains("cell.pressure") && Catch::Contains("never rise from 0"));
  from_zero.set_value("programme.load", "false");
  from_zero.set_value("programme.unload", "false");
  CHECK_NOTHROW(ProgrammeSettings::from_scene(from_zero));
  auto too_high = Scene::from_string(small_programme(10000), "bad", {"programme.top_pressure=1e9"});
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(too_high), Catch::Contains("programme.top_pressure") && Catch::Contains("out of range"));
  // A drag floor above the quench's drag, given, is refused rather than clamped to it silently. The default
  // floor under a smaller drag keeps that drag, and with no step-down (patience 0) the floor does not matter.
  auto high_floor = Scene::from_string(small_programme(10000), "bad", {"programme.quench_drag=0.5", "programme.quench_drag_min=2"});
  CHECK_THROWS_WITH(ProgrammeSettings::refuse_floor_above_drag(high_floor),
                    Catch::Contains("programme.quench_drag_min") && Catch::Contains("value 2 ") && Catch::Contains("<= programme.quench_drag"));
  high_floor.set_value("programme.quench_patience", "0");
  CHECK_NOTHROW(ProgrammeSettings::refuse_floor_above_drag(high_floor));
  const auto low_drag = Scene::from_string(small_programme(10000), "ok", {"programme.quench_drag=0.1"});
  CHECK_NOTHROW(ProgrammeSettings::refuse_floor_above_drag(low_drag));
  // The stored scene a resume reads spells out the default floor, and the resume reads it with from_scene alone,
  // which does not refuse it
  CHECK_NOTHROW(ProgrammeSettings::from_scene(Scene::from_string(low_drag.resolved_toml(), "stored")));
}

TEST_CASE("bonded clusters: connected components of the contact and bond graph", "[programme]") {
  std::vector<NetworkInteraction> links{{0, 1, -1e-4, 1.0}, {2, 3, 5e-4, -0.5}};
  CHECK(count_bonded_clusters(5, links) == 3);   // {0,1}, {2,3}, {4}
  links.push_back({1, 2, -1e-4, 0.0});
  links.push_back({3, 4, 1e-4, -0.1});
  CHECK(count_bonded_clusters(5, links) == 1);
  CHECK(count_bonded_clusters(3, {}) == 3);
}

TEST_CASE("programme: stopped inside a stage and continued from its state and progress, it ends as the unbroken one",
          "[programme][checkpoint]") {
  auto scene = Scene::from_string(small_programme(400000), "programme");
  const auto settings = ProgrammeSettings::from_scene(scene);
  // Both programmes save at the same checks of stage 1 (saving changes nothing; the schedule is as it was when a
  // save restarted CVODE): every 2000 steps, and the unbroken one also at its first check with the quench on,
  // which is where the other continues from. From there on the two must agree to the last bit.
  std::vector<std::byte> saved;
  StageProgress at;
  auto saving = [&](Simulation& s, bool unbroken) {
    return [&s, &saved, &at, unbroken](const StageRecord& r, long, const StageProgress& p) {
      const bool resume_point = unbroken && saved.empty() && !p.quench.empty() && p.quench[0] == 1;
      if (r.index == 1 && (r.steps % 2000 == 0 || resume_point)) {
        auto bytes = s.save_state();
        if (resume_point) saved = std::move(bytes), at = p;
      }
      return false;
    };
  };
  auto a = Simulation::create(scene);
  const auto whole = run_programme(*a, settings, {}, saving(*a, true));
  REQUIRE(!saved.empty());   // the quench was on in stage 1: its counters are part of what continues
  CHECK(at.stage == 1);
  CHECK(at.quench.size() == 9);
  CHECK(StageProgress::from_values(at.values(), settings, a->dt()).steps == at.steps);

  auto b = Simulation::create(scene);
  b->restore_state(saved);
  const auto rest = run_programme(*b, settings, {}, saving(*b, false), at);
  REQUIRE(whole.size() == 3);
  REQUIRE(rest.size() == 2);
  for (std::size_t k = 0; k < rest.size(); ++k) {
    const StageRecord &x = whole[k + 1], &y = rest[k];
    INFO("stage " << x.index);
    CHECK(y.index == x.index);
    CHECK(y.steps == x.steps);
    CHECK(y.reached == x.reached);
    CHECK(y.time == x.time);
    CHECK(y.quench_start == x.quench_start);
    CHECK(y.quench_drag == x.quench_drag);
    REQUIRE(y.values.size() == x.values.size());
    for (std::size_t v = 0; v < x.values.size(); ++v) {
      INFO(x.values[v].first);
      CHECK((y.values[v].second == x.values[v].second || (std::isnan(x.values[v].second) && std::isnan(y.values[v].second))));
    }
  }
  CHECK(b->save_state() == a->save_state());
}

TEST_CASE("programme: a stage's progress that does not fit the programme is refused", "[programme][checkpoint]") {
  const auto settings = ProgrammeSettings::from_scene(Scene::from_string(small_programme(1000), "programme"));
  const double dt = 1e-4;
  CHECK_THROWS_WITH(StageProgress::from_values({7, 100}, settings, dt), Catch::Contains("3 stages"));
  CHECK_THROWS_WITH(StageProgress::from_values({1, 1000}, settings, dt), Catch::Contains("budget of 1000"));
  CHECK_THROWS_WITH(StageProgress::from_values({1, 100, 0, 1}, settings, dt), Catch::Contains("quench has 2 numbers"));
  CHECK(StageProgress::from_values({2, 0}, settings, dt).stage == 2);
}

TEST_CASE("programme: a ramped first compression raises the target linearly, then waits its budget", "[programme][ramp]") {
  // 12 type-1 grains; the target ramps from 0 to P* = 0.01 over T = 0.5 (ceil(T / dt) rounded up to checks).
  auto scene = type1_packing(12, 3, 1.0, 0.0, 3000);
  scene.set_value("programme.first_compression_time", "0.5");
  auto s = Simulation::create(scene);
  const long ramp = long(std::ceil(0.5 / s->dt() / 100)) * 100;
  std::vector<std::pair<long, double>> seen;   // (steps into the stage, target) at each check
  const auto stages = run_programme(*s, ProgrammeSettings::from_scene(scene), {},
                                    [&](const StageRecord& r, long, const StageProgress&) {
                                      seen.emplace_back(r.steps, s->get("cell.pressure"));
                                      return false;
                                    });
  REQUIRE(stages.size() == 1);
  REQUIRE(ramp == 6300);
  CHECK(stages[0].steps <= ramp + 3000);   // the budget counts from the ramp's end
  CHECK(stages[0].steps > ramp);
  for (const auto& [steps, target] : seen) {
    INFO("step " << steps);
    // Over each chunk the target of its first step: 0.01 (steps - 100) / ramp, then 0.01.
    CHECK(target == (steps <= ramp ? 0.01 * double(steps - 100) / double(ramp) : 0.01));
  }
  CHECK(seen.front().second == 0.0);
  // Without the ramp the same stage starts at the full pressure; a cohesionless programme has no ramp to give.
  auto stepped = type1_packing(12, 3, 1.0, 0.0, 3000);
  auto t = Simulation::create(stepped);
  double first = -1;
  run_programme(*t, ProgrammeSettings::from_scene(stepped), {}, [&](const StageRecord&, long, const StageProgress&) {
    if (first < 0) first = t->get("cell.pressure");
    return false;
  });
  CHECK(first == 0.01);
  auto none = Scene::from_string(small_programme(1000), "bad", {"programme.first_compression_time=10"});
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(none), Catch::Contains("programme.first_compression_time"));
}

TEST_CASE("programme: a ramped first compression stopped inside and after its ramp continues as the unbroken one",
          "[programme][ramp][checkpoint]") {
  auto scene = type1_packing(12, 3, 1.0, 0.0, 3000);
  scene.set_value("programme.first_compression_time", "0.5");
  const auto settings = ProgrammeSettings::from_scene(scene);
  // The ramp takes 6300 steps here (dt = 8.0e-5): stopped inside it and after it.
  auto probe = Simulation::create(scene);
  REQUIRE(long(std::ceil(0.5 / probe->dt() / 100)) * 100 == 6300);
  for (const long stop_at : {3000L, 6700L}) {
    INFO("stopped at step " << stop_at);
    std::vector<std::byte> saved;
    StageProgress at;
    auto a = Simulation::create(scene);
    const auto whole = run_programme(*a, settings, {}, [&](const StageRecord& r, long, const StageProgress& p) {
      if (r.steps == stop_at) saved = a->save_state(), at = p;   // both runs save here
      return false;
    });
    REQUIRE(!saved.empty());
    // As a checkpoint stores and reads it: past the stage budget of 3000 after the ramp, still the stage's own.
    CHECK(StageProgress::from_values(at.values(), settings, a->dt()).steps == stop_at);
    // ... but not past the budget after the ramp (6300 + 3000 steps).
    std::vector<double> beyond = at.values();
    beyond[1] = 9300;
    CHECK_THROWS_WITH(StageProgress::from_values(beyond, settings, a->dt()), Catch::Contains("after a ramp of 6300 steps"));
    beyond[1] = 9299;
    CHECK(StageProgress::from_values(beyond, settings, a->dt()).steps == 9299);
    auto b = Simulation::create(scene);
    b->restore_state(saved);
    const auto rest = run_programme(*b, settings, {}, {}, at);
    REQUIRE(whole.size() == 1);
    REQUIRE(rest.size() == 1);
    CHECK(rest[0].steps == whole[0].steps);
    CHECK(b->save_state() == a->save_state());
  }
}

TEST_CASE("programme: a background drag in a ramped first compression above P* = 1 resumes as the unbroken one",
          "[programme][ramp][checkpoint]") {
  // The background drag is gamma T / T with T the inertial time at the target, which above P* = 1 depends on it:
  // the stage must set it at its own target, not at where the ramp stands (0 at the start, else at a resume).
  auto scene = type1_packing(12, 3, 1.0, 0.0, 3000);
  scene.set_value("cell.pressure", "2.0");
  scene.set_value("programme.background_drag", "0.5");
  scene.set_value("programme.first_compression_time", "6.0");
  const auto settings = ProgrammeSettings::from_scene(scene);
  for (const long stop_at : {60000L, 74000L}) {
    INFO("stopped at step " << stop_at);
    std::vector<std::byte> saved;
    StageProgress at;
    auto a = Simulation::create(scene);
    REQUIRE(long(std::ceil(6.0 / a->dt() / 100)) * 100 > stop_at);   // inside the ramp
    const auto whole = run_programme(*a, settings, {}, [&](const StageRecord& r, long, const StageProgress& p) {
      if (r.steps == stop_at) saved = a->save_state(), at = p;
      return false;
    });
    REQUIRE(!saved.empty());
    REQUIRE(a->get("contacts") > 0);
    auto b = Simulation::create(scene);
    b->restore_state(saved);
    const auto rest = run_programme(*b, settings, {}, {}, at);
    REQUIRE(rest.size() == 1);
    CHECK(rest[0].steps == whole[0].steps);
    CHECK(b->save_state() == a->save_state());
  }
}

TEST_CASE("programme: stopped between two checks (StopPoll) and continued, it ends as the unbroken one",
          "[programme][ramp][checkpoint]") {
  // A Ctrl-C was read only at the checks (programme.check_every): the poll between them stops the programme there,
  // inside the ramp (its target set at the last check) and after it; the continued stage goes on to the next check.
  auto scene = type1_packing(12, 3, 1.0, 0.0, 3000);
  scene.set_value("programme.first_compression_time", "0.5");
  const auto settings = ProgrammeSettings::from_scene(scene);   // checks every 100 steps, a ramp of 6300
  for (const long stop_at : {3050L, 6770L}) {
    INFO("stopped at step " << stop_at);
    std::vector<std::byte> saved;
    StageProgress at;
    auto a = Simulation::create(scene);
    // The unbroken programme saves where the other stops.
    const StopPoll saving{[&] {
                            if (a->step_count() == stop_at) saved = a->save_state();
                            return false;
                          }, 10};
    const auto whole = run_programme(*a, settings, {}, {}, {}, saving);
    REQUIRE(!saved.empty());
    auto c = Simulation::create(scene);
    long polls = 0, checked_at = -1;
    const StopPoll stopping{[&] { return ++polls, c->step_count() == stop_at; }, 10};
    const auto part = run_programme(*c, settings, {}, [&](const StageRecord& r, long, const StageProgress& p) {
      if (r.steps % 100 == 0) return false;
      checked_at = r.steps, at = p;
      return true;
    }, {}, stopping);
    CHECK(part.empty());
    CHECK(checked_at == stop_at);
    CHECK(at.steps == stop_at);
    CHECK(c->save_state() == saved);
    auto b = Simulation::create(scene);
    b->restore_state(saved);
    const auto rest = run_programme(*b, settings, {}, {}, at, StopPoll{[] { return false; }, 10});
    REQUIRE(whole.size() == 1);
    REQUIRE(rest.size() == 1);
    CHECK(rest[0].steps == whole[0].steps);
    CHECK(rest[0].reached == whole[0].reached);
    CHECK(b->save_state() == a->save_state());
  }
}
