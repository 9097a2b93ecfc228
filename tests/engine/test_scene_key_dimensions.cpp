// Every number of the scene schema declares its dimension, a pure number's too: the FMUs' parameter units, the
// scene reference's unit column and the unit-scaling tests read it there, so a number with none would be
// forgotten by all three.
#include <catch2/catch.hpp>

#include "io/scene.hpp"

using namespace grains;

TEST_CASE("every number in the scene schema declares its dimension, and text and switches none", "[units]") {
  int numbers = 0;
  for (const auto& e : scene_schema()) {
    INFO(e.path);
    const bool number = e.kind == ValueKind::real || e.kind == ValueKind::integer || e.kind == ValueKind::real_array ||
                        e.kind == ValueKind::real_matrix;
    CHECK(e.dimension.has_value() == number);
    numbers += number;
    // An integer counts something (particles, steps, checks): in other units it would no longer be one.
    if (e.kind == ValueKind::integer && e.dimension) CHECK(*e.dimension == Dimension{});
  }
  CHECK(numbers > 60);
}

TEST_CASE("a key's SI unit is written as the engine's outputs write theirs, per area for disks", "[units]") {
  CHECK(scene_key_unit("particles.density", 3) == "kg/m^3");
  CHECK(scene_key_unit("particles.density", 2) == "kg/m^2");
  CHECK(scene_key_unit("adhesion.stiffness", 2) == "N/m");
  CHECK(scene_key_unit("particles.kinetic_energy", 2) == "J");
  CHECK(scene_key_unit("gravity.G", 3) == "m^3/(kg s^2)");
  CHECK(scene_key_unit("particles.velocities", 3) == "m/s");
  CHECK(scene_key_unit("drag.rate", 3) == "1/s");
  CHECK(scene_key_unit("contact.restitution", 3) == "");   // a pure number
  CHECK(scene_key_unit("particles.layout", 3) == "");      // text
  CHECK(si_unit(Dimension{.length = 2, .mass = 1, .time = -1}, 3) == "kg m^2/s");   // an angular momentum's
  CHECK_THROWS(scene_key_unit("particles.colour", 3));
}
