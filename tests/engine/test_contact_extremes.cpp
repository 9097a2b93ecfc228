// The contact law at its extremes: restitution 1e-4 and 1, stiffness over six decades, size ratio 10,
// the time-step rule's boundary, and a blow-up that must stop with a clear error.
#include <catch2/catch.hpp>

#include <cmath>
#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Contains;

namespace {

std::string dense_box(double e, double tc, const std::string& extra = "") {
  return fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "random"
count = 150
size_distribution = "uniform"
diameter_min = 0.5
diameter_max = 1.0
solid_fraction = 0.25
velocity = "gaussian"
kinetic_energy = 1.0
seed = 11
[contact]
restitution = {}
duration = {}
overlap_limit = 1.0
[friction]
coefficient = 0.3
[run]
threads = 1
{}
)", e, tc, extra);
}

}  // namespace

TEST_CASE("energy never grows in a dense frictional system, e from 1e-4 to 0.99, stiffness over six decades", "[extremes]") {
  for (double e : {1e-4, 0.3, 0.99})
    for (double tc : {1.0, 0.1, 0.01, 0.001}) {   // k_n grows as 1/t_c^2: six decades
      auto sim = Simulation::create(Scene::from_string(dense_box(e, tc), "dense"));
      double previous = sim->get("kinetic_energy") + sim->get("elastic_energy");
      const double start = previous;
      double worst_rise = 0;
      for (int k = 0; k < 400; ++k) {
        sim->step_n(1);
        const double now = sim->get("kinetic_energy") + sim->get("elastic_energy");
        REQUIRE(std::isfinite(now));
        worst_rise = std::max(worst_rise, (now - previous) / start);
        previous = now;
      }
      INFO("e = " << e << ", t_c = " << tc << ": largest one-step rise of K + elastic energy " << worst_rise);
      // The stored elastic energy at the sampled instant lags the dissipation within a step: allow
      // a rise of O(dt^2) of the energy, far below a real instability.
      CHECK(worst_rise < 1e-3);
      CHECK(previous < start);
    }
}

TEST_CASE("e = 1 conserves energy to second order in dt", "[extremes]") {
  // Frictionless elastic gas: the largest deviation of the total energy from its start over many
  // collisions (sampled every 0.01) falls as dt^2.
  auto drift = [](double nc) {
    std::string text = dense_box(1.0, 0.05, fmt::format("[time]\nsteps_per_contact = {}\n", nc));
    text.replace(text.find("coefficient = 0.3"), 17, "coefficient = 0.0");
    auto sim = Simulation::create(Scene::from_string(text, "elastic"));
    const double e0 = sim->get("kinetic_energy") + sim->get("elastic_energy");
    double worst = 0;
    for (int k = 0; k < 100; ++k) {
      sim->step(0.01);
      worst = std::max(worst, std::abs(sim->get("kinetic_energy") + sim->get("elastic_energy") - e0) / e0);
    }
    return worst;
  };
  const double coarse = drift(50), fine = drift(100);
  INFO("largest relative energy error up to t = 1: n_c = 50: " << coarse << ", n_c = 100: " << fine);
  CHECK(coarse < 1e-4);
  CHECK(coarse / fine > 3.0);   // second order gives 4
}

TEST_CASE("the time-step rule warns past t_c / 20 and names both numbers", "[extremes]") {
  auto at_rule = Simulation::create(Scene::from_string(dense_box(0.5, 0.02, "[time]\ndt = 0.001\n"), "dt"));
  CHECK(at_rule->warnings().empty());
  auto past = Simulation::create(Scene::from_string(dense_box(0.5, 0.02, "[time]\ndt = 0.00106\n"), "dt"));
  REQUIRE(past->warnings().size() == 1);
  CHECK_THAT(past->warnings()[0], Contains("0.00106") && Contains("0.001"));
}

TEST_CASE("a non-finite value stops the run with an error naming the particle and the step", "[extremes]") {
  // The overlap clamp keeps contact forces finite even far past the step rule, so overflow is
  // provoked directly: velocities near the largest double overflow the positions in a few steps.
  const char* text = R"(
[scene]
dimension = 3
[particles]
layout = "list"
positions = [[0, 0, 0], [5, 0, 0]]
velocity = "list"
velocities = [[1e307, 0, 0], [0, 0, 0]]
[box]
periodic = false
[contact]
restitution = 0.9
duration = 0.05
[time]
dt = 100.0
)";
  auto sim = Simulation::create(Scene::from_string(text, "overflow"));
  CHECK_THROWS_WITH(sim->step_n(10), Contains("non-finite") && Contains("particle 0") && Contains("step"));
}
