// A key given twice by --set: with two values the last one silently won (`--set time.steps=5 --set time.steps=6`
// ran 6, while two different run-length keys were refused); it is refused naming the key and both values. The
// same value twice passes: whichever wins, the scene is the same.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "io/scene.hpp"
#include "plain_lattice_scene.hpp"

using namespace grains;
using Catch::Contains;

namespace {

Scene with(const std::vector<std::string>& overrides) {
  return Scene::from_string(plain_lattice_scene(), "twice.toml", overrides);
}

}  // namespace

TEST_CASE("scene overrides given twice: two values of one key are refused naming the key and both", "[scene][errors]") {
  CHECK_THROWS_WITH(with({"time.steps=5", "time.steps=6"}),
                    Contains("--set time.steps: given twice, as 5 and as 6: give each key once"));
  CHECK_THROWS_WITH(with({"contact.restitution=0.3", "run.threads=1", "contact.restitution=0.4"}),
                    Contains("--set contact.restitution: given twice, as 0.3 and as 0.4"));
  CHECK_THROWS_WITH(with({"scene.name=a", "scene.name=b"}), Contains("--set scene.name: given twice, as a and as b"));
}

TEST_CASE("scene overrides given twice: the same value twice passes, compared as read", "[scene]") {
  CHECK(with({"time.steps=5", "time.steps=5"}).integer("time.steps") == 5);
  CHECK(with({"contact.restitution=0.5", "contact.restitution=5e-1"}).real("contact.restitution") == 0.5);
  CHECK(with({"scene.name=a", "scene.name=\"a\""}).text("scene.name") == "a");
}
