// The random layout numbers its particles along a Z-order curve (protocols/initial_state.cpp): close in
// space means close in memory, and each thread's contiguous share of the particles is a slab of space.
// The sizes move with the positions (no overlaps), in 2D and 3D.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "polydisperse_particles.hpp"

using namespace grains;

namespace {

Scene polydisperse_gas(int dimension, int count, double solid_fraction = 0, int seed = 11) {
  const double phi = solid_fraction > 0 ? solid_fraction : dimension == 2 ? 0.36 : 0.2;
  return Scene::from_string(polydisperse_particles(dimension, count, phi, seed) + R"(
[box]
periodic = true
[contact]
duration = 0.05
[run]
threads = 1
)", "layout");
}

// Minimum-image distance between particles i and j.
double distance(const ParticleView& P, const BoxView& B, std::size_t i, std::size_t j) {
  double s = 0;
  for (int a = 0; a < P.dimension; ++a) {
    double d = P.position[P.dimension * j + a] - P.position[P.dimension * i + a];
    d -= B.length[a] * std::round(d / B.length[a]);
    s += d * d;
  }
  return std::sqrt(s);
}

}  // namespace

TEST_CASE("random layout: particles are numbered along a Z-order curve, sizes moving with positions", "[layout]") {
  for (const auto& [dimension, count] : {std::pair{2, 1400}, std::pair{3, 1000}}) {
    INFO(dimension << "D, " << count << " particles");
    const auto s = Simulation::create(polydisperse_gas(dimension, count));
    const auto P = s->particles();
    const auto B = s->box();
    const double L = B.length[0];
    // Consecutive particles are near in space: about 1.5 mean spacings L / N^(1/D) apart on average
    // here, where random numbering gives about 0.4 L (15 spacings in 2D, 5 in 3D).
    const double spacing = L / std::pow(double(count), 1.0 / dimension);
    double consecutive = 0;
    for (std::size_t i = 0; i + 1 < P.count; ++i) consecutive += distance(P, B, i, i + 1);
    consecutive /= double(P.count - 1);
    CHECK(consecutive < 2.5 * spacing);
    // The curve's leading bit is the last axis: the first half of the particles fills the lower half of
    // the box along it (up to the one particle that may straddle the split), the second the upper.
    const int last = dimension - 1;
    std::size_t misplaced = 0;
    for (std::size_t i = 0; i < P.count; ++i) {
      const bool lower = P.position[dimension * i + last] - B.lower[last] < 0.5 * B.length[last];
      misplaced += lower != (i < P.count / 2);
    }
    CHECK(misplaced <= std::size_t(0.02 * double(P.count)));
    // Sizes moved with their positions: the insertion's no-overlap guarantee still holds.
    double worst = 0;
    for (std::size_t i = 0; i < P.count; ++i)
      for (std::size_t j = i + 1; j < P.count; ++j)
        worst = std::max(worst, P.radius[i] + P.radius[j] - distance(P, B, i, j));
    CHECK(worst <= 0);
  }
}

TEST_CASE("random layout: polydisperse spheres at solid fraction 0.3 start for every seed", "[layout]") {
  // In the particles' order the insertion jams near 0.3 for most seeds of the 3D consolidation scenes (a
  // large sphere finds no hole late in the filling; seeds 2-5 of 1000 fail so); it then
  // places them largest first.
  for (int seed = 1; seed <= 5; ++seed) {
    INFO("seed " << seed);
    const auto s = Simulation::create(polydisperse_gas(3, 1000, 0.3, seed));
    const auto P = s->particles();
    const auto B = s->box();
    double worst = -1, solid = 0;
    for (std::size_t i = 0; i < P.count; ++i) {
      solid += 4.0 / 3.0 * M_PI * std::pow(P.radius[i], 3);
      for (std::size_t j = i + 1; j < P.count; ++j)
        worst = std::max(worst, P.radius[i] + P.radius[j] - distance(P, B, i, j));
    }
    CHECK(worst <= 0);
    CHECK(solid / (B.length[0] * B.length[1] * B.length[2]) == Approx(0.3).epsilon(1e-9));
  }
}
