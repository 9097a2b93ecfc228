// The springs of a contact (tangential and rolling) live in its neighbour-list entry. They are not
// cleared when the contact opens, only when it touches again; and across a rebuild only the
// contacts of the last evaluation carry theirs. Either way a contact that opens and touches again
// must start relaxed: the same whether its list entry survived the gap (a wide skin) or was dropped
// and made afresh (a skin so thin that the list is rebuilt at every step).
#include <catch2/catch.hpp>

#include <string>

#include "adhesive_scene.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {

// Two cohesionless grains (F0 = 0) with friction and rolling resistance, held together by weak
// self-gravity: an oblique, spinning collision, a low bounce, and a second collision.
std::string bouncing_pair(int dim, double skin) {
  ListedParticles p;
  p.positions = {std::vector<double>(dim, 0.0), std::vector<double>(dim, 0.0)};
  p.positions[1][0] = 1.05, p.positions[1][1] = 0.3;
  p.velocities = {std::vector<double>(dim, 0.0), std::vector<double>(dim, 0.0)};
  p.velocities[0][0] = 0.2, p.velocities[1][0] = -0.2, p.velocities[1][1] = -0.1;
  p.diameters = {1, 1};
  p.masses = {1, 1};
  const std::string spins = dim == 2 ? "angular_velocities = [[1.0], [-2.0]]"
                                     : "angular_velocities = [[0.3, -0.2, 1.0], [0.5, 0.4, -2.0]]";
  return adhesive_scene(dim, p,
                        fmt::format("force = 0.0\nrestitution = 0.5\n[friction]\ncoefficient = 0.5\n[rolling]\n"
                                    "coefficient = 0.005\n[gravity]\nenabled = true\nG = 0.1\n[neighbours]\nskin = {}\n",
                                    skin),
                        spins);
}

}  // namespace

TEST_CASE("a contact that opens and touches again starts with relaxed springs, its list entry kept or not",
          "[contact][friction][rolling]") {
  for (int dim : {2, 3}) {
    auto kept = Simulation::create(Scene::from_string(bouncing_pair(dim, 2.0), "kept"));
    auto remade = Simulation::create(Scene::from_string(bouncing_pair(dim, 1e-6), "remade"));
    int touches = 0;
    bool touching = false;
    for (int k = 0; k < 4000 && touches < 3; ++k) {   // touches at steps ~1500, ~28500, ~37800 (2D)
      kept->step_n(20), remade->step_n(20);   // a contact lasts ~60 steps
      const bool now = kept->get("contacts") > 0;
      touches += now && !touching;
      touching = now;
    }
    INFO("dimension " << dim << ": " << touches << " touches, list builds " << kept->get("neighbour_builds") << " and "
                      << remade->get("neighbour_builds"));
    REQUIRE(touches >= 2);
    REQUIRE(kept->get("neighbour_builds") == 1.0);           // the entry survived every gap
    REQUIRE(remade->get("neighbour_builds") > 100.0);        // rebuilt over and over
    CHECK(kept->particles().velocity == remade->particles().velocity);
    CHECK(kept->particles().angular_velocity == remade->particles().angular_velocity);
  }
}
