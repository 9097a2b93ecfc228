// Benchmark, hidden from the suite (run: grains_tests "[.neighbour-bench]"): neighbour-list build time
// for N = 20,000 spheres at solid fraction 0.3, monodisperse against size ratios 2 and 10.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "neighbours/neighbour_list.hpp"

using namespace grains;

TEST_CASE("neighbour build cost against polydispersity", "[.neighbour-bench]") {
  for (double dmin : {1.0, 0.5, 0.1}) {
    const int N = 20000;
    std::mt19937_64 rng(1);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<double> radius(N);
    double volume = 0;
    for (auto& r : radius) r = 0.5 * (dmin + (1 - dmin) * u(rng)), volume += 4.0 / 3.0 * M_PI * r * r * r;
    Box<3> box;
    const double L = std::cbrt(volume / 0.3);
    box.length.setConstant(L);
    box.periodic = {true, true, true};
    std::vector<Vec<3>> x(N);
    for (auto& p : x) p = Vec<3>(u(rng) * L, u(rng) * L, u(rng) * L);   // overlaps do not matter for timing
    NeighbourList<3> nl;
    nl.configure(0.0, 0.1 * dmin);
    nl.build(x, radius, box, 1);
    const int reps = 20;
    const auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps; ++k) nl.build(x, radius, box, 1);
    const double ms = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps * 1e3;
    WARN(fmt::format("diameters in [{}, 1]: {:.2f} ms per build ({:.0f} ns/particle, 1 thread), {} pairs", dmin, ms,
                     ms * 1e6 / N, nl.pair_count()));
    CHECK(nl.pair_count() > 0);
  }
}
