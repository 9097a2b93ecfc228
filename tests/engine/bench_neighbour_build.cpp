// Benchmark, hidden from the suite (run: grains_tests "[.neighbour-bench]"): neighbour-list build time
// for N = 20,000 spheres at solid fraction 0.3, monodisperse against size ratios 2 and 10, in random
// index order and in cell order (neighbours close in memory too, as after a lattice set-up).
#include <catch2/catch.hpp>

#include <ctime>
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
    // Processor time, not wall time: on a shared machine the wall clock also counts other processes.
    const std::clock_t t0 = std::clock();
    for (int k = 0; k < reps; ++k) nl.build(x, radius, box, 1);
    const double ms = double(std::clock() - t0) / CLOCKS_PER_SEC / reps * 1e3;
    WARN(fmt::format("diameters in [{}, 1]: {:.2f} ms per build ({:.0f} ns/particle, 1 thread), {} pairs", dmin, ms,
                     ms * 1e6 / N, nl.pair_count()));
    CHECK(nl.pair_count() > 0);
  }
}
