// A host that sets the target pressure to a value a rounding away from the one in force (fmpy's interpolation of
// a constant input gives 0.01 at most communication points and one ulp off at others) makes no new target:
// CVODE keeps its history (each such ulp restarted it). A real change still restarts it.
#include <catch2/catch.hpp>

#include <cmath>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "packed_cell_scene.hpp"

using namespace grains;

TEST_CASE("barostat: a target one rounding away from the one in force is no new target", "[barostat]") {
  const std::string text = packed_cell_scene(2, 100, 1e-3);
  auto steady = Simulation::create(Scene::from_string(text, "cell2d"));
  auto jittered = Simulation::create(Scene::from_string(text, "cell2d"));
  for (int k = 0; k < 300; ++k) {
    steady->step_n(1);
    jittered->set("cell.pressure", k % 3 == 0 ? std::nextafter(1e-3, 0.0) : k % 3 == 1 ? 1e-3 : std::nextafter(1e-3, 1.0));
    jittered->step_n(1);
  }
  CHECK(jittered->get("cvode_reinitialisations") == steady->get("cvode_reinitialisations"));
  jittered->set("cell.pressure", 1.001e-3);   // a real change
  jittered->step_n(1);
  CHECK(jittered->get("cvode_reinitialisations") == steady->get("cvode_reinitialisations") + 1);
}
