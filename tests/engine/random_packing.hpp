// A random polydisperse packing with its neighbour list, shared by the pair-filter and shell-list tests:
// diameters in [0.1, 1], dense enough for many contacts (900 disks or 1500 spheres), in an open or
// periodic box with an offset corner; the list is built with skin 0.2 and the given interaction range,
// then every particle moves by up to `move` (not re-wrapped, as between two builds in the engine).
#pragma once
#include <random>
#include <vector>

#include "core/box.hpp"
#include "neighbours/neighbour_list.hpp"

namespace grains {

template <int D>
struct Packing {
  std::vector<Vec<D>> x;
  std::vector<double> radius;
  Box<D> box;
  NeighbourList<D> list;
};

template <int D>
Packing<D> random_packing(bool periodic, double range, unsigned seed, double move) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Packing<D> p;
  const std::size_t n = D == 3 ? 1500 : 900;
  const double edge = D == 3 ? 8.0 : 24.0;
  for (int a = 0; a < D; ++a) p.box.length[a] = edge * (1 + 0.1 * a), p.box.lower[a] = -1.5 + a, p.box.periodic[a] = periodic;
  for (std::size_t i = 0; i < n; ++i) {
    Vec<D> x;
    for (int a = 0; a < D; ++a) x[a] = p.box.lower[a] + u(rng) * p.box.length[a];
    p.x.push_back(x);
    p.radius.push_back(0.5 * (0.1 + 0.9 * u(rng)));
  }
  p.list.configure(range, 0.2);
  p.list.build(p.x, p.radius, p.box, 1);
  std::normal_distribution<double> g(0, 1);
  for (auto& x : p.x) {
    Vec<D> d;
    for (int a = 0; a < D; ++a) d[a] = g(rng);
    x += move * u(rng) * d.normalized();
  }
  return p;
}

}  // namespace grains
