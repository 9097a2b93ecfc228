// The check of a given layout for coincident and deeply overlapping pairs (protocols/initial_overlaps.cpp) finds
// what testing every pair finds, for sizes spread over many size classes, and stays fast with one grain far larger
// than the rest: its grid had cells one largest diameter wide, and a bed of small grains around a large one made the
// check quadratic (a test below took about a minute).
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <type_traits>

#include "protocols/initial_overlaps.hpp"

using namespace grains;

namespace {

template <int D>
InitialOverlaps every_pair(const Particles<D>& P, const Box<D>& box, double limit) {
  InitialOverlaps found;
  for (std::size_t i = 0; i < P.size(); ++i)
    for (std::size_t j = i + 1; j < P.size(); ++j) {
      const double d = box.minimum_image(P.position[j] - P.position[i]).norm();
      const double rmin = std::min(P.radius[i], P.radius[j]), overlap = P.radius[i] + P.radius[j] - d;
      if (d == 0 && !found.coincident) found.coincident = true, found.same_i = i, found.same_j = j;
      if (!(overlap > limit * rmin)) continue;
      ++found.deep;
      if (overlap / rmin > found.ratio) found.i = i, found.j = j, found.overlap = overlap, found.ratio = overlap / rmin;
    }
  return found;
}

// n grains in a box of edge L (periodic on the axes given), radii log-uniform over `decades`, a few placed on others.
template <int D>
Particles<D> scattered(std::size_t n, double L, double decades, unsigned seed, Box<D>& box, std::array<bool, D> periodic) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  box.length = Vec<D>::Constant(L), box.lower = Vec<D>::Constant(-0.3 * L), box.periodic = periodic;
  Particles<D> P;
  P.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int a = 0; a < D; ++a) P.position[i][a] = box.lower[a] + u(rng) * L;
    P.radius[i] = 0.05 * std::pow(10.0, decades * u(rng) * u(rng));   // mostly small, some far larger
  }
  P.position[n - 1] = P.position[n / 2], P.position[n - 3] = P.position[n / 3];   // two coincident pairs
  return P;
}

template <int D>
void agrees_with_every_pair(std::array<bool, D> periodic, double decades, unsigned seed) {
  Box<D> box;
  const Particles<D> P = scattered<D>(D == 2 ? 1500 : 1200, 20.0, decades, seed, box, periodic);
  for (const double limit : {0.0, 0.1}) {
    const InitialOverlaps a = find_initial_overlaps<D>(P, box, limit), b = every_pair<D>(P, box, limit);
    CAPTURE(D, decades, seed, limit);
    CHECK(a.deep == b.deep);
    CHECK(a.ratio == b.ratio);
    CHECK(a.overlap == b.overlap);
    CHECK(a.coincident == b.coincident);
    CHECK(a.same_i == b.same_i);
    CHECK(a.same_j == b.same_j);
    CHECK(a.i == b.i);
    CHECK(a.j == b.j);
    CHECK(b.deep > 0);
  }
}

}  // namespace

TEST_CASE("initial overlaps: the same pairs as testing every pair, sizes over several classes", "[initial-overlaps]") {
  for (unsigned seed : {1u, 2u}) {
    agrees_with_every_pair<2>({true, true}, 0.2, seed);    // one class
    agrees_with_every_pair<2>({true, false}, 2.5, seed);   // eight classes and more
    agrees_with_every_pair<2>({false, false}, 1.0, seed);
    agrees_with_every_pair<3>({true, true, true}, 2.5, seed);
    agrees_with_every_pair<3>({false, true, false}, 1.0, seed);
  }
}

TEST_CASE("initial overlaps: one grain far larger than a bed of small ones is no quadratic check", "[initial-overlaps]") {
  // 90,000 small disks on a square lattice in a periodic box, one of 400 diameters over them: the old single grid
  // had one cell, so 4e9 pairs.
  Box<2> box;
  box.length = Vec<2>::Constant(360.0), box.periodic = {true, true};
  Particles<2> P;
  P.resize(90001);
  for (std::size_t k = 0; k < 90000; ++k) P.position[k] = Vec<2>(double(k % 300) * 1.2, double(k / 300) * 1.2), P.radius[k] = 0.5;
  P.position[90000] = Vec<2>(180.3, 180.3), P.radius[90000] = 200;
  std::size_t deep = 0;   // the small disks do not touch one another: the pairs are the large one's
  double ratio = 0;
  for (std::size_t k = 0; k < 90000; ++k) {
    const double overlap = 200.5 - box.minimum_image(P.position[90000] - P.position[k]).norm();
    if (overlap > 0.1 * 0.5) ++deep, ratio = std::max(ratio, overlap / 0.5);
  }
  const InitialOverlaps o = find_initial_overlaps<2>(P, box, 0.1);
  CHECK(deep > 70000);
  CHECK(o.deep == deep);
  CHECK(o.ratio == ratio);
  CHECK(o.i < 90000);
  CHECK(o.j == 90000);
  CHECK_FALSE(o.coincident);
  // The cost as pairs measured, not time (a timed test fails on a slow machine): the single grid measured 4e9.
  INFO("pairs tested: " << o.pairs_tested);
  CHECK(o.pairs_tested < 20 * P.size());
}

TEST_CASE("initial overlaps: of equally deep pairs, the one with the lowest indices is named", "[initial-overlaps]") {
  // Pair (1, 5): a small disk on a large one; pair (2, 3): two small ones; both overlap by half the small radius
  // (exactly, in binary). The size classes' grids visit (1, 5) at the large grain 5, after (2, 3): they named (2, 3),
  // where testing every pair in index order (and the single grid before them) names (1, 5).
  auto check = [](auto dim) {
    constexpr int D = decltype(dim)::value;
    Box<D> box;
    box.length = Vec<D>::Constant(100.0), box.lower = Vec<D>::Constant(-50.0), box.periodic.fill(false);
    Particles<D> P;
    P.resize(6);
    P.radius = {1, 0.25, 0.25, 0.25, 0.25, 1};
    for (int i = 0; i < 6; ++i) P.position[i] = Vec<D>::Constant(10.0 * i - 30);
    P.position[1] = P.position[5], P.position[1][0] += 1.125;
    P.position[3] = P.position[2], P.position[3][0] += 0.375;
    const InitialOverlaps o = find_initial_overlaps<D>(P, box, 0.1);
    CAPTURE(D);
    CHECK(o.deep == 2);
    CHECK(o.ratio == 0.5);
    CHECK(o.i == 1);
    CHECK(o.j == 5);
  };
  check(std::integral_constant<int, 2>{});
  check(std::integral_constant<int, 3>{});
}

TEST_CASE("initial overlaps: many large grains among many far smaller ones are no quadratic check", "[initial-overlaps]") {
  // 40,000 disks of radius 1 and 40,000 of 0.001 spread thin: a large grain searching the tiny ones' grid within its
  // own reach scanned a million cells or, fewer, every tiny grain: 1.6e9 pairs (about 3.5 s here, now 0.06 s).
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 500);
  Box<2> box;
  box.length = Vec<2>::Constant(500.0), box.periodic = {false, false};
  Particles<2> P;
  P.resize(80000);
  for (std::size_t i = 0; i < 80000; ++i) P.position[i] = Vec<2>(u(rng), u(rng)), P.radius[i] = i % 2 ? 1e-3 : 1.0;
  const InitialOverlaps o = find_initial_overlaps<2>(P, box, 0.1);
  CHECK(o.deep > 1000);
  INFO("pairs tested: " << o.pairs_tested);
  CHECK(o.pairs_tested < 20 * P.size());
}
