// Every class of bad scene is refused with a message naming the key, the value and what is allowed.
#include <catch2/catch.hpp>

#include <string>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Contains;

namespace {
const std::string base = R"(
[scene]
dimension = 3
[particles]
layout = "lattice"
count = 27
solid_fraction = 0.2
[contact]
restitution = 0.5
duration = 0.05
)";

void build(const std::string& text, const std::vector<std::string>& overrides = {}) {
  Simulation::create(Scene::from_string(text, "test.toml", overrides));
}
}  // namespace

TEST_CASE("unknown keys and sections are named, with a suggestion", "[scene]") {
  REQUIRE_THROWS_WITH(build(base + "restitutoin = 0.3\n"), Contains("contact.restitutoin") && Contains("did you mean 'contact.restitution'"));
  REQUIRE_THROWS_WITH(build(base + "[walls]\nx = 1\n"), Contains("unknown section [walls]"));
  REQUIRE_THROWS_WITH(build(base, {"contact.stiffnes=3"}), Contains("contact.stiffnes"));
  REQUIRE_THROWS_WITH(build(base, {"contact.restitution"}), Contains("expected key.path=value"));
}

TEST_CASE("wrong types and out-of-range values name key, value and range", "[scene]") {
  REQUIRE_THROWS_WITH(build(base, {"contact.restitution=\"high\""}), Contains("contact.restitution") && Contains("expected a number"));
  REQUIRE_THROWS_WITH(build(base, {"contact.restitution=1.5"}), Contains("contact.restitution") && Contains("1.5") && Contains("(0, 1]"));
  REQUIRE_THROWS_WITH(build(base, {"contact.restitution=0"}), Contains("value 0 is out of range"));
  REQUIRE_THROWS_WITH(build(base, {"particles.diameter=-1"}), Contains("particles.diameter") && Contains("-1") && Contains("(0, inf]"));
  REQUIRE_THROWS_WITH(build(base, {"scene.dimension=4"}), Contains("scene.dimension") && Contains("[2, 3]"));
  REQUIRE_THROWS_WITH(build(base, {"scene.dimension=2.5"}), Contains("expected an integer"));
  REQUIRE_THROWS_WITH(build(base, {"particles.layout=\"grid\""}), Contains("\"grid\"") && Contains("lattice, random, list, file"));
  REQUIRE_THROWS_WITH(build(base, {"box.periodic=1"}), Contains("box.periodic") && Contains("true or false"));
}

TEST_CASE("all problems of a scene are listed at once", "[scene]") {
  REQUIRE_THROWS_WITH(build(base, {"contact.restitution=2", "particles.seed=-3"}),
                      Contains("2 problems") && Contains("contact.restitution") && Contains("particles.seed"));
}

TEST_CASE("TOML syntax errors carry the line", "[scene]") {
  REQUIRE_THROWS_WITH(build("[scene]\ndimension = 3\n[contact\n"), Contains("test.toml:3") && Contains("syntax"));
}

TEST_CASE("inconsistent layouts are explained", "[scene]") {
  REQUIRE_THROWS_WITH(build(base, {"particles.count=30"}), Contains("particles.count") && Contains("n^3") && Contains("27"));
  REQUIRE_THROWS_WITH(build(base, {"particles.solid_fraction=0.6"}), Contains("overlap"));
  REQUIRE_THROWS_WITH(build(base, {"particles.layout=\"random\"", "particles.solid_fraction=0.7", "particles.count=200"}),
                      Contains("random insertion could not place"));
  REQUIRE_THROWS_WITH(build(base, {"particles.layout=\"list\"", "particles.positions=[[0,0,0],[2,0,0]]", "particles.diameters=[1.0]",
                                   "box.periodic=false"}),
                      Contains("particles.diameters") && Contains("1 values for 2 positions"));
  REQUIRE_THROWS_WITH(build(base, {"particles.layout=\"list\"", "particles.positions=[[0,0],[2,0]]", "box.periodic=false"}),
                      Contains("a 3D scene needs 3"));
  REQUIRE_THROWS_WITH(build(base, {"particles.count=8", "box.lengths=[2.0, 2.0, 2.0]", "particles.diameter=0.9"}),
                      Contains("box.lengths") && Contains("periodic box must be longer"));
  REQUIRE_THROWS_WITH(build(base, {"contact.duration=0"}), Contains("contact.duration"));
}
