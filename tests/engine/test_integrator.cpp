// The integrator's first half (core/integrator.hpp) on random particles: the velocity Verlet update
// and the velocity predictor against their formulas written out here, the previous forces cleared for
// the coming evaluation, and the displacement it measures while moving the particles equal to the
// neighbour list's own largest_move, which decides when the list is rebuilt.
#include <catch2/catch.hpp>

#include <random>

#include "core/integrator.hpp"
#include "neighbours/neighbour_list.hpp"

using namespace grains;

namespace {

template <int D>
void first_half_case(unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::size_t N = 301;   // not a multiple of any vector width
  Particles<D> P;
  P.resize(N);
  Box<D> box;
  for (int a = 0; a < D; ++a) box.length[a] = 12.0, box.lower[a] = 0.0, box.periodic[a] = true;
  for (std::size_t i = 0; i < N; ++i) {
    P.set_mass_and_radius(i, 1.0 + 0.5 * (u(rng) + 1), 0.3 + 0.1 * u(rng));
    for (int a = 0; a < D; ++a) {
      P.position[i][a] = 6.0 + 5.5 * u(rng);
      P.velocity[i][a] = u(rng), P.force[i][a] = 3 * u(rng), P.force_prev[i][a] = 3 * u(rng);
    }
  }
  NeighbourList<D> nl;
  nl.configure(0.0, 0.4);
  nl.build(P.position, P.radius, box, 1);
  const Particles<D> before = P;
  const double h = 0.01;
  const auto sums = kick_drift_predict<D, false>(P, h, 0, N, nl.unscaled_reference(N));
  double witness = 0;
  for (std::size_t i = 0; i < N; ++i)
    for (int a = 0; a < D; ++a) {
      const double acc = P.inv_mass[i] * before.force[i][a], acc_prev = P.inv_mass[i] * before.force_prev[i][a];
      const double v = before.velocity[i][a] + 0.5 * h * acc;
      CHECK(P.velocity[i][a] == v);
      CHECK(P.position[i][a] == before.position[i][a] + h * v);
      CHECK(P.velocity_predicted[i][a] == v + 0.5 * h * (1.75 * acc - 0.75 * acc_prev));
      CHECK(P.force_prev[i][a] == 0.0);
      CHECK(P.force[i][a] == before.force[i][a]);
      witness += P.position[i][a];
    }
  CHECK(sums.witness == Approx(witness).epsilon(1e-12));
  REQUIRE(sums.largest_move > 0);
  CHECK(sums.largest_move == nl.largest_move(P.position, 0, N));
  // Without the reference (a deforming cell, or no list) nothing is measured.
  P = before;
  CHECK(kick_drift_predict<D, false>(P, h, 0, N, nullptr).largest_move == 0.0);
}

}  // namespace

TEST_CASE("integrator: the first half's update, prediction and measured move (2D and 3D)", "[integrator]") {
  for (unsigned seed : {1u, 2u, 3u}) {
    first_half_case<2>(seed);
    first_half_case<3>(seed);
  }
}
