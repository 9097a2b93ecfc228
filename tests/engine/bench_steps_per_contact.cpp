// Benchmark, hidden from the suite (run: grains_tests "contact resolution: n_c cost and accuracy table"): the
// n_c table docs/speed.md quotes. Tagged with the gravity benchmarks (bench_gravity.cpp): docs/speed.md's one
// command prints both.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "cloud_scene.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "load_average.hpp"

using namespace grains;

// n_c (steps per contact duration): cost and accuracy against the finest setting. Cost: wall time of
// a fixed stretch (0.05 time units, from the start) of a 500-grain self-gravitating cloud with contacts
// on (the aggregation scene's set-up; the cost per step is gravity's, so cost follows n_c); accuracy: realised restitution of a head-on collision (e = 0.5) against n_c = 1600,
// and the kinetic energy an elastic (e = 1) collision fails to return.
TEST_CASE("contact resolution: n_c cost and accuracy table", "[.gravity-bench]") {
  auto head_on = [](double e, double nc) {
    auto sim = Simulation::create(Scene::from_string(fmt::format(R"(
[particles]
layout = "list"
positions = [[0, 0, 0], [1.0137, 0, 0]]
velocity = "list"
velocities = [[0.5, 0, 0], [-0.5, 0, 0]]
diameter = 1.0
mass = 1.0
[box]
periodic = false
[contact]
restitution = {}
duration = 1.0
overlap_limit = 1.0
[time]
steps_per_contact = {}
[run]
threads = 1
)", e, nc), "head-on"));
    const double k0 = sim->get("kinetic_energy");
    sim->step(3.0);
    const auto p = sim->particles();
    return std::pair{p.velocity[3] - p.velocity[0], sim->get("kinetic_energy") / k0};
  };
  const double e_ref = head_on(0.5, 1600).first;
  auto cloud_seconds = [](double nc) {
    auto sim = Simulation::create(Scene::from_string(
        cloud_scene({.count = 500, .seed = 5, .restitution = 0.5, .duration = 0.02, .threads = 2},
                    fmt::format("[time]\nsteps_per_contact = {}\n", nc)),
        "cloud"));
    const auto t0 = std::chrono::steady_clock::now();
    sim->step(0.05);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  const double cost_ref = cloud_seconds(1600);
  WARN(fmt::format("1-min load average {}", load_average()));
  WARN(fmt::format("n_c table (reference n_c = 1600: e = {:.8f}, cloud {:.3g} s): n_c | cloud s | cost / finest | "
                   "|e - e_ref| / e_ref | 1 - K_out / K_in (e = 1)", e_ref, cost_ref));
  for (double nc : {10, 20, 30, 50, 100, 200, 400}) {
    const double e = head_on(0.5, nc).first, energy = head_on(1.0, nc).second;
    const double s = cloud_seconds(nc);
    WARN(fmt::format("  {:4} | {:.3g} | {:.3f} | {:.2g} | {:.2g}", nc, s, s / cost_ref, std::abs(e / e_ref - 1), 1 - energy));
  }
}
