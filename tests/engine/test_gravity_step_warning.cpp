// The gravity time-step rule (physics.md section 3): a step above T_orb / 20, T_orb the circular orbit
// of the two heaviest particles at their closest approach, is warned about with both numbers.
#include <catch2/catch.hpp>

#include <cmath>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Matchers::Contains;

namespace {

// Three particles of masses 1, 3, 2 (the heaviest pair: 5) and diameters 0.2, 0.1, 0.2 (R_min = 0.05);
// eps = 0.5 R_min = 0.025.
std::string scene(bool contacts, double dt) {
  return fmt::format(R"(
[particles]
layout = "list"
positions = [[0, 0, 0], [2, 0, 0], [0, 2, 0]]
diameters = [0.2, 0.1, 0.2]
masses = [1.0, 3.0, 2.0]
[box]
periodic = false
[contact]
{}
[gravity]
enabled = true
G = 2.0
softening = 0.5
[time]
dt = {:.17g}
[run]
threads = 1
)", contacts ? "enabled = true\nduration = 1.0" : "enabled = false", dt);
}

}  // namespace

TEST_CASE("gravity step rule: warns past T_orb / 20 and names both numbers", "[gravity]") {
  const double pi = std::acos(-1.0), eps = 0.025, G = 2.0, M = 5.0;
  for (bool contacts : {false, true}) {
    const double d = contacts ? 0.1 : 0.0;   // touching: 2 R_min
    const double orbit = 2 * pi * std::sqrt(std::pow(d * d + eps * eps, 1.5) / (G * M));
    INFO("contacts " << contacts << ", T_orb " << orbit);
    auto below = Simulation::create(Scene::from_string(scene(contacts, orbit / 21), "below"));
    CHECK(below->warnings().empty());
    auto past = Simulation::create(Scene::from_string(scene(contacts, orbit / 19), "past"));
    REQUIRE(past->warnings().size() == 1);
    CHECK_THAT(past->warnings()[0], Contains("T_orb") && Contains(fmt::format("{:.6g}", orbit / 19)) &&
                                        Contains(fmt::format("{:.6g}", orbit / 20)));
  }
}
