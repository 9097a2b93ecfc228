// Every variable of every shipped scene says what it is: the runner's summary and the FMUs' model
// descriptions show these texts (until 2026-12-05 the force modules' observables said only "see the README").
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
