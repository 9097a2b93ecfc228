// Every variable of every shipped scene says what it is: the runner's summary and the FMUs' model
// descriptions show these texts.
#include <catch2/catch.hpp>

#include <string>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;

TEST_CASE("every variable of the shipped scenes has a description", "[observables]") {
  for (const char* name : {"aggregation", "medea", "collapse", "gas", "gas-friction", "collision-2d", "consolidation",
                           "consolidation-rr-3d", "cohesionless"}) {
    auto s = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/" + name + ".toml", {"run.threads=1"}));
    for (const auto& v : s->variables()) {
      INFO(name << ": " << v.name << ": '" << v.description << "'");
      CHECK(v.description.size() >= 5);
      CHECK(v.description.find("undescribed") == std::string::npos);
      CHECK(v.description.find("README") == std::string::npos);
    }
    for (const auto& v : s->variables())   // energies in J, like the kinetic energy
      if (v.name.ends_with("_energy")) CHECK(v.unit == "J");
  }
}

TEST_CASE("each force-histogram bin's description gives its own range", "[observables]") {
  // Only the first bin's text says it also holds what is below.
  auto s = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/consolidation.toml", {"run.threads=1"}));
  int seen = 0;
  for (const auto& v : s->variables()) {
    if (!v.name.starts_with("force_histogram_")) continue;
    ++seen;
    INFO(v.name << ": '" << v.description << "'");
    CHECK(v.description.find("first bin") == std::string::npos);
    if (v.name == "force_histogram_00") CHECK(v.description.find("below -0.5") != std::string::npos);
    if (v.name == "force_histogram_05") CHECK(v.description.find("in [1.5, 2)") != std::string::npos);
    if (v.name == "force_histogram_20") CHECK(v.description.find(">= 9") != std::string::npos);
  }
  CHECK(seen == 21);
}

TEST_CASE("declared units: stresses and moduli per length in 2D and per area in 3D and G with its dimension", "[observables]") {
  // A 2D stress is a force per length, not "Pa" (the FMUs' model descriptions show these units), and G has a
  // dimension.
  for (const char* name : {"consolidation", "consolidation-3d", "aggregation"}) {
    auto s = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/" + name + ".toml", {"run.threads=1"}));
    const std::string stress = s->dimension() == 3 ? "Pa" : "N/m";
    int seen = 0;
    for (const auto& v : s->variables()) {
      INFO(name << ": " << v.name << " [" << v.unit << "]");
      const bool pressure = v.name == "pressure" || v.name == "pressure_kinetic";
      const bool modulus = v.name == "B" || v.name == "G" || v.name.starts_with("B_") || v.name.starts_with("G_") ||
                           (v.name.size() == 3 && v.name[0] == 'C');
      if (v.name.starts_with("stress_") || pressure || modulus) {
        CHECK(v.unit == stress);
        ++seen;
      }
      if (v.name == "gravity.G") {
        CHECK(v.unit == "m^3/(kg s^2)");
        ++seen;
      }
    }
    CHECK(seen > 0);
  }
}

TEST_CASE("a variable named after a scene key has the key's unit, the schema's", "[observables][units]") {
  // The engine's parameters and controls (time.dt, adhesion.force, gravity.G, drag.rate, ...) take their units from
  // the schema, not from a table of their own that could disagree with it.
  int seen = 0;
  for (const char* name : {"aggregation", "collision", "consolidation", "consolidation-rr-3d", "cohesionless"}) {
    auto s = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/" + name + ".toml", {"run.threads=1"}));
    for (const auto& v : s->variables()) {
      if (!find_schema_entry(v.name)) continue;
      INFO(name << ": " << v.name << " [" << v.unit << "]");
      CHECK(v.unit == scene_key_unit(v.name, s->dimension()));
      seen += !v.unit.empty();
    }
  }
  CHECK(seen >= 10);
}

TEST_CASE("the reduced pressure's description gives this scene's P*, the cohesionless one too", "[observables]") {
  // Every scene's P* read "a P / F0 (2D), a^2 P / F0 (3D)", also where F0 = 0 (cell.force_unit = 0) and P* is
  // P a^(D-2) / k_n, which the descriptions did not name: a P* of 1e-5 read as a P / F0 with F0 = 0.
  struct Case {
    const char* scene;
    std::vector<std::string> overrides;
    const char* reduced;
  };
  const std::vector<std::string> cohesionless = {"adhesion.force=0", "cell.force_unit=0", "cell.pressure=1e-5"};
  for (const Case& c : {Case{"consolidation", {}, "a P / F0"}, Case{"consolidation-3d", {}, "a^2 P / F0"},
                        Case{"cohesionless", {}, "P / k_n"}, Case{"consolidation-3d", cohesionless, "a P / k_n"}}) {
    std::vector<std::string> overrides = c.overrides;
    overrides.push_back("run.threads=1");
    auto s = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/" + c.scene + ".toml", overrides));
    int seen = 0;
    for (const auto& v : s->variables()) {
      if (v.name != "pressure_reduced" && v.name != "cell.pressure") continue;
      INFO(c.scene << " with " << c.overrides.size() << " overrides: " << v.name << ": '" << v.description << "'");
      CHECK(v.description.find(c.reduced) != std::string::npos);
      for (const char* other : {"a P / F0", "a^2 P / F0", "P / k_n", "a P / k_n"})
        if (std::string_view(other) != c.reduced && std::string_view(c.reduced).find(other) == std::string_view::npos)
          CHECK(v.description.find(other) == std::string::npos);
      ++seen;
    }
    CHECK(seen == 2);
  }
}
