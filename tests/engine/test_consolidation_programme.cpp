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
  auto low_top = Scene::from_string(small_programme(10), "bad", {"programme.top_pressure=1e-4"});
  CHECK_THROWS_WITH(ProgrammeSettings::from_scene(low_top), Catch::Contains("programme.top_pressure"));
}

TEST_CASE("bonded clusters: connected components of the contact and bond graph", "[programme]") {
  std::vector<NetworkInteraction> links{{0, 1, -1e-4, 1.0}, {2, 3, 5e-4, -0.5}};
  CHECK(count_bonded_clusters(5, links) == 3);   // {0,1}, {2,3}, {4}
  links.push_back({1, 2, -1e-4, 0.0});
  links.push_back({3, 4, 1e-4, -0.1});
  CHECK(count_bonded_clusters(5, links) == 1);
  CHECK(count_bonded_clusters(3, {}) == 3);
}
