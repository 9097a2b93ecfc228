// A cell too light for the step: its breathing against the contacts, stepped with the particles' forces frozen
// over a step, grows every step (cell.mass = 1e-4 m blows a 100-disk cell up to a solid fraction of 0.07). Warned
// at set-up below M_c = k_cell dt^2, k_cell = K_N (L / a)^(D-2).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "packed_cell_scene.hpp"
#include "warnings_of.hpp"

using namespace grains;
using Catch::Contains;

namespace {
long light_cell_warnings(const Simulation& s) { return warnings_of(s, "the lightest cell the step follows"); }
}  // namespace

TEST_CASE("a cell lighter than the step can follow is warned about, and is unstable", "[barostat][extremes]") {
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    auto probe = Simulation::create(Scene::from_string(packed_cell_scene(dim, 64, 0.01), "probe"));
    REQUIRE(light_cell_warnings(*probe) == 0);   // the default mass m (L / a)^(D-2) is far above the bound
    const double L = probe->get("cell_length_x"), dt = probe->dt(), kn = probe->get("contact.k_n");
    const double a = 1.0;   // the packing's largest diameter
    const double bound = kn * std::pow(L / a, dim - 2) * dt * dt;
    // The strain-rate cap lifted, so that only the step decides: a third of the bound heats the compressing gas
    // without end or crushes the cell within the run (the engine stops a cell shorter than twice the interaction
    // reach); three times the bound compresses it calmly.
    struct Outcome { long warned; double hottest; bool stopped; };
    const auto run = [&](double mass) {
      auto s = Simulation::create(Scene::from_string(
          packed_cell_scene(dim, 64, 0.01, fmt::format("mass = {}\ninertia_number = 100", mass)), "light"));
      Outcome o{light_cell_warnings(*s), 0.0, false};
      try {
        for (int chunk = 0; chunk < 30; ++chunk) {
          s->step(100 * s->dt());
          o.hottest = std::max(o.hottest, s->get("kinetic_energy"));
        }
      } catch (const std::exception& e) {
        o.stopped = true;   // the collapse names the light cell as a cause
        CHECK_THAT(e.what(), Contains("the cell has shrunk") && Contains("a heavier cell.mass"));
      }
      return o;
    };
    const Outcome light = run(bound / 3), heavy = run(3 * bound);
    CHECK(light.warned == 1);
    CHECK(heavy.warned == 0);
    REQUIRE_FALSE(heavy.stopped);
    CHECK((light.stopped || light.hottest > 20 * heavy.hottest));
  }
}

TEST_CASE("a strain-rate cap so low that the cell cannot move in any run is warned about", "[barostat][extremes]") {
  // cell.inertia_number = 1e-20 (or a force unit far below the scene's forces, T0 = sqrt(a m / F0) huge) held the cell
  // still with P* far from its target. Warned where 1 % of strain takes 1e9 steps.
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    const auto cell = [&](const char* inertia) {
      return Simulation::create(Scene::from_string(packed_cell_scene(dim, 64, 0.01, inertia), "capped"));
    };
    auto usual = cell(""), frozen = cell("inertia_number = 1e-20");
    CHECK(warnings_of(*usual, "cell.inertia_number") == 0);
    REQUIRE(warnings_of(*frozen, "cell.inertia_number") == 1);
    CHECK_THAT(frozen->warnings().back(), Contains("cannot follow its target pressure in any run"));
    const double L = frozen->get("cell_length_x");
    usual->step_n(1000), frozen->step_n(1000);
    CHECK(usual->get("cell_length_x") < 0.99 * L);                          // the gas compresses
    CHECK(frozen->get("cell_length_x") == Approx(L).epsilon(1e-12));   // the warning is no false alarm
  }
}
