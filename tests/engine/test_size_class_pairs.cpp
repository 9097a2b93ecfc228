// The size classes' pair search (neighbours/size_class_pairs.hpp) that the starting-overlap check and the cluster
// analysis share: every pair closer than R_i + R_j + gap (by the minimum image) is visited, none twice, each from
// its smaller grain or, within one class, from its lower index; for sizes over many classes, narrow periodic boxes
// (one or two cells an axis), grains spread over many cells (the hashed grids) or few (the plain arrays), and
// grains far out of the box.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <set>
#include <utility>

#include "neighbours/size_class_pairs.hpp"
#include "neighbours/size_classes.hpp"

using namespace grains;

namespace {

template <int D>
void finds_every_pair_once(std::array<bool, D> periodic, double length, double spread, double decades, double gap,
                           unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Box<D> box;
  box.lower = Vec<D>::Constant(-0.4 * length), box.length = Vec<D>::Constant(length), box.periodic = periodic;
  const std::size_t N = 700;
  std::vector<Vec<D>> x(N);
  std::vector<double> r(N);
  for (std::size_t i = 0; i < N; ++i) {
    for (int a = 0; a < D; ++a) x[i][a] = box.lower[a] + (u(rng) - 0.5) * spread * length + 0.5 * length;
    r[i] = 0.05 * std::pow(10.0, decades * u(rng) * u(rng));
  }
  x[N - 1] = x[N / 2];   // a coincident pair
  const SizeClasses sizes(*std::max_element(r.begin(), r.end()), *std::min_element(r.begin(), r.end()));
  std::set<std::pair<std::size_t, std::size_t>> seen;
  std::size_t visits = 0;
  bool oriented = true;
  SizeClassPairs<D>(x, r, gap, box).for_each_pair([&](std::size_t i, std::size_t j) {
    ++visits;
    seen.insert({std::min(i, j), std::max(i, j)});
    const int ci = sizes.of(r[i]), cj = sizes.of(r[j]);
    oriented = oriented && i != j && (cj < ci || (cj == ci && j > i));
  });
  std::size_t near = 0, missed = 0;
  for (std::size_t i = 0; i < N; ++i)
    for (std::size_t j = i + 1; j < N; ++j)
      if (box.minimum_image(x[j] - x[i]).norm() < r[i] + r[j] + gap) ++near, missed += !seen.count({i, j});
  CAPTURE(D, periodic, length, spread, decades, gap, seed);
  CHECK(near > 0);
  CHECK(missed == 0);
  CHECK(visits == seen.size());
  CHECK(oriented);
}

}  // namespace

TEST_CASE("size class pairs: every pair within reach, each once, over classes, boxes and spreads", "[size-class-pairs]") {
  for (unsigned seed : {1u, 2u}) {
    finds_every_pair_once<2>({false, false}, 30.0, 1.0, 0.2, 0.0, seed);     // one class, a plain array
    finds_every_pair_once<2>({false, false}, 30.0, 1e4, 2.5, 0.1, seed);     // spread thin: hashed grids
    finds_every_pair_once<2>({true, false}, 20.0, 1.0, 2.5, 0.0, seed);      // many classes, one axis periodic
    finds_every_pair_once<2>({true, true}, 0.9, 1.0, 1.0, 0.02, seed);      // a box one or two cells wide
    finds_every_pair_once<2>({true, true}, 10.0, 5.0, 1.0, 0.0, seed);      // grains several boxes out
    finds_every_pair_once<3>({false, false, false}, 12.0, 1.0, 2.0, 0.05, seed);
    finds_every_pair_once<3>({true, true, true}, 12.0, 1.0, 2.5, 0.0, seed);
    finds_every_pair_once<3>({false, true, false}, 1.5, 1.0, 1.0, 0.0, seed);
    finds_every_pair_once<3>({false, false, false}, 12.0, 1e5, 1.0, 0.0, seed);
  }
}
