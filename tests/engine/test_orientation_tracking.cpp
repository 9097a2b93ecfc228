// particles.track_orientation = false: the orientations are neither integrated nor reported, and nothing
// else changes (positions, velocities and spins bit for bit), in 2D and 3D with friction; with it on (the
// default) every 3D orientation stays a unit quaternion and turns.
#include <catch2/catch.hpp>

#include <cmath>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {

Scene frictional_gas(int dimension, bool track) {
  return Scene::from_string(fmt::format(R"(
[scene]
dimension = {}
[particles]
layout = "random"
count = 200
solid_fraction = 0.3
velocity = "gaussian"
track_orientation = {}
[box]
periodic = true
[contact]
restitution = 0.7
duration = 0.05
[friction]
coefficient = 0.5
[time]
dt = 0.001
[run]
threads = 1
)", dimension, track), "orientation");
}

template <int D>
void compare() {
  auto on = Simulation::create(frictional_gas(D, true)), off = Simulation::create(frictional_gas(D, false));
  on->step_n(3000), off->step_n(3000);
  const auto a = on->particles(), b = off->particles();
  CHECK(a.position == b.position);
  CHECK(a.velocity == b.velocity);
  CHECK(a.angular_velocity == b.angular_velocity);
  CHECK(b.orientation.empty());
  REQUIRE(a.orientation.size() == a.count * (D == 3 ? 4 : 1));
  double turned = 0;
  for (std::size_t i = 0; i < a.count; ++i) {
    if constexpr (D == 3) {
      const double* q = &a.orientation[4 * i];
      CHECK(std::abs(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3] - 1) < 1e-12);
      turned = std::max(turned, 1 - std::abs(q[0]));
    } else {
      turned = std::max(turned, std::abs(a.orientation[i]));
    }
  }
  CHECK(turned > 1e-3);   // the grains spin (friction), and their orientations follow
}

}  // namespace

TEST_CASE("orientation tracking off changes nothing but the orientations (3D)", "[orientation]") { compare<3>(); }
TEST_CASE("orientation tracking off changes nothing but the orientations (2D)", "[orientation]") { compare<2>(); }
