// The angular-momentum observable in a periodic cell is the one the written (wrapped) positions give:
// the engine wraps its own positions only when it rebuilds its lists, so between rebuilds a grain that
// crossed the boundary sits one cell outside, and an observable from those positions could not be
// reproduced from the output.
#include <catch2/catch.hpp>

#include <cmath>

#include "core/simulation.hpp"
#include "head_on_scene.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {
// L_z about the origin from the view's positions (the ones the output writes).
double written_angular_momentum_z(const Simulation& s) {
  const auto v = s.particles();
  double L = 0;
  for (std::size_t i = 0; i < v.count; ++i)
    L += v.mass[i] * (v.position[2 * i] * v.velocity[2 * i + 1] - v.position[2 * i + 1] * v.velocity[2 * i]);
  return L;
}
}  // namespace

TEST_CASE("angular momentum in a periodic cell is the written positions'", "[observables]") {
  // One free disk moving across the +x face of a 10 x 10 cell: x goes 9.7 -> about 10.3 in 0.2 time units,
  // far less than the list's skin, so no rebuild wraps it in between.
  ListedParticles p;
  p.positions = {{9.7, 5.0}};
  p.velocities = {{3.0, 1.0}};
  p.diameters = {1.0};
  p.masses = {1.0};
  std::string text = listed_particles_toml(2, p);
  const std::string open = "[box]\nperiodic = false\n";
  text.replace(text.find(open), open.size(), "[box]\nperiodic = true\nlengths = [10.0, 10.0]\n");
  text += "[contact]\nenabled = false\n[time]\ndt = 0.01\n";
  auto s = Simulation::create(Scene::from_string(text, "crossing disk"));
  bool crossed = false;
  for (int k = 0; k < 20; ++k) {
    s->step(0.01);
    const double x = s->particles().position[0];
    crossed = crossed || x < 1;   // wrapped to the cell's start
    CHECK(s->get("angular_momentum_z") == Approx(written_angular_momentum_z(*s)).epsilon(1e-14).margin(1e-14));
  }
  CHECK(crossed);
}
