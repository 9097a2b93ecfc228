// The damped-packing step rule (core/dashpot_stability.hpp): the stability limit of the integrator's
// predicted-velocity dashpot; a light grain in a cage of twelve heavy ones, and an FCC crystal of equal
// grains (whose fastest mode moves neighbours against each other), each settling with a step just below
// the predicted limit and heating up above it, with the start-up warning saying so.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/dashpot_stability.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Contains;

TEST_CASE("dashpot stability: the predicted-velocity limit, undamped and damped", "[integrator][stability]") {
  // Without damping the scheme is velocity Verlet: stable up to w h = 2.
  CHECK(predicted_dashpot_limit(0.0) == Approx(2.0).epsilon(1e-9));
  // Damped limits from an independent scan of the same one-step matrix (NumPy, 200-point grids, 60 bisections):
  // zeta 0.3 -> 0.800, 0.9 -> 0.3098, 2 -> 0.1421, 3 -> 0.0950.
  CHECK(predicted_dashpot_limit(0.3) == Approx(0.800).epsilon(2e-3));
  CHECK(predicted_dashpot_limit(0.9) == Approx(0.3098).epsilon(1e-3));
  CHECK(predicted_dashpot_limit(2.0) == Approx(0.1421).epsilon(1e-3));
  CHECK(predicted_dashpot_limit(3.0) == Approx(0.0950).epsilon(1e-3));
  // No stable island above the limit, no unstable one below it.
  for (double zeta : {0.0, 0.5, 1.0, 2.0}) {
    const double limit = predicted_dashpot_limit(zeta);
    for (int k = 1; k <= 100; ++k) {
      INFO("zeta " << zeta << ", w h = " << k / 100.0 * limit);
      CHECK(predicted_dashpot_growth(k / 100.0 * limit * (1 - 1e-9), zeta) <= 1 + 1e-12);
      if (k > 2) CHECK(predicted_dashpot_growth(k / 100.0 * 2.0 * limit + limit, zeta) > 1);
    }
  }
}

namespace {

// The contacts of both packings below: e = 0.0015 (zeta = 0.9004) and t_c = 0.02 for the lightest pair.
std::string damped_contacts(double steps_per_contact) {
  return fmt::format("[contact]\nrestitution = 0.0015\nduration = 0.02\n[time]\nsteps_per_contact = {}\n[run]\nthreads = 1\n",
                     steps_per_contact);
}

// Both packings' fastest mode: 12/3 contacts' spring and dashpot on a reduced mass m* (the caged grain's
// own mass against heavy walls; half a grain's in the crystal, against the grain's half stiffness), so
// w = 2 w0 and the damping ratio on it is 2 zeta; with w0 t_c = pi / sqrt(1 - zeta^2) the step is stable
// for t_c / h above 2 pi / (sqrt(1 - zeta^2) limit(2 zeta)) = 91.6.
double predicted_steps_per_contact() {
  const double pi = std::acos(-1.0), zeta = -std::log(0.0015) / std::hypot(pi, std::log(0.0015));
  return 2 * pi / (std::sqrt(1 - zeta * zeta) * predicted_dashpot_limit(2 * zeta));
}

// A grain of mass 1 (diameter 1.1) in an FCC cage of twelve grains of mass 1e6 (diameter 0.9), each
// overlapping it by 0.001 and clear of each other. The centre starts with a small velocity.
std::string cage(double steps_per_contact) {
  std::vector<std::string> positions = {"[0, 0, 0]"}, masses = {"1.0"}, diameters = {"1.1"};
  const double s = 0.999 / std::sqrt(2.0);
  for (int plane = 0; plane < 3; ++plane)
    for (int a : {-1, 1})
      for (int b : {-1, 1}) {
        double p[3] = {0, 0, 0};
        p[plane] = a * s, p[(plane + 1) % 3] = b * s;
        positions.push_back(fmt::format("[{}, {}, {}]", p[0], p[1], p[2]));
        masses.push_back("1e6"), diameters.push_back("0.9");
      }
  std::vector<std::string> velocities(13, "[0, 0, 0]");
  velocities[0] = "[1e-3, 2e-4, -5e-4]";
  return fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "list"
positions = [{}]
velocity = "list"
velocities = [{}]
diameters = [{}]
masses = [{}]
[box]
periodic = false
)", fmt::join(positions, ", "), fmt::join(velocities, ", "), fmt::join(diameters, ", "), fmt::join(masses, ", ")) +
         damped_contacts(steps_per_contact);
}

double centre_speed(const Simulation& sim) {
  const auto p = sim.particles();
  return std::hypot(p.velocity[0], p.velocity[1], p.velocity[2]);
}

}  // namespace

TEST_CASE("dashpot stability: a light grain caged by twelve damped contacts settles only below the predicted step",
          "[integrator][stability]") {
  const double threshold = predicted_steps_per_contact();
  CHECK(threshold == Approx(91.6).epsilon(1e-3));
  for (double factor : {0.87, 1.04}) {
    auto sim = Simulation::create(Scene::from_string(cage(factor * threshold), "cage"));
    const bool warned = !sim->warnings().empty() && sim->warnings()[0].find("pressed by 12 damped contacts") != std::string::npos;
    sim->step(2.0);   // 100 contact durations
    INFO("steps per contact " << factor * threshold << ": centre speed 1.1e-3 -> " << centre_speed(*sim));
    if (factor < 1) {
      CHECK(warned);
      CHECK(centre_speed(*sim) > 1e-7);   // still rattling (measured 3.7e-6 at 80 steps per contact)
    } else {
      CHECK_FALSE(warned);
      CHECK(centre_speed(*sim) < 1e-8);   // settled (2.8e-10: the heavy grains' slow recession)
    }
  }
}

namespace {

// 108 equal grains (diameter 1, mass 1) on a periodic FCC lattice of 3 x 3 x 3 cells, each overlapping its
// twelve neighbours by 0.001, with small Gaussian velocities.
std::string fcc_crystal(double steps_per_contact) {
  const double cell = 0.999 * std::sqrt(2.0);
  std::vector<std::string> positions;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (const auto& b : {std::array{0.0, 0.0, 0.0}, {0.5, 0.5, 0.0}, {0.5, 0.0, 0.5}, {0.0, 0.5, 0.5}})
          positions.push_back(fmt::format("[{}, {}, {}]", (i + b[0] + 0.25) * cell, (j + b[1] + 0.25) * cell,
                                          (k + b[2] + 0.25) * cell));
  return fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "list"
positions = [{}]
diameter = 1.0
mass = 1.0
velocity = "gaussian"
kinetic_energy = 1e-7
seed = 5
[box]
periodic = true
lengths = [{}, {}, {}]
)", fmt::join(positions, ", "), 3 * cell, 3 * cell, 3 * cell) + damped_contacts(steps_per_contact);
}

}  // namespace

TEST_CASE("dashpot stability: an FCC crystal of equal grains settles only below the predicted step",
          "[integrator][stability]") {
  // The crystal's fastest mode moves neighbouring planes in antiphase: w^2 = (12/3) k / m* with m* = 1/2,
  // the same 91.6 steps per contact as the cage (where m* ~ 1 but the walls stand still).
  const double threshold = predicted_steps_per_contact();
  for (double factor : {0.75, 1.05}) {
    auto sim = Simulation::create(Scene::from_string(fcc_crystal(factor * threshold), "fcc"));
    REQUIRE(sim->get("contacts") == 6 * 108);
    const bool warned = !sim->warnings().empty() && sim->warnings()[0].find("damped contacts") != std::string::npos;
    const double start = sim->get("kinetic_energy");
    double largest = start;
    for (int k = 0; k < 40; ++k) sim->step(0.05), largest = std::max(largest, sim->get("kinetic_energy"));
    INFO("steps per contact " << factor * threshold << ": kinetic energy " << start << " -> largest " << largest
                              << ", last " << sim->get("kinetic_energy"));
    if (factor < 1) {
      CHECK(warned);
      CHECK(largest > 10 * start);   // the antiphase mode grows
    } else {
      CHECK_FALSE(warned);
      CHECK(largest < 2 * start);
      CHECK(sim->get("kinetic_energy") < 0.01 * start);
    }
  }
}
