#include "protocols/initial_overlaps.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>
#include <utility>
#include <vector>

#include "neighbours/size_classes.hpp"

namespace grains {

template <int D>
InitialOverlaps find_initial_overlaps(const Particles<D>& P, const Box<D>& box, double overlap_limit) {
  InitialOverlaps found;
  const std::size_t N = P.size();
  if (N < 2) return found;
  // Size classes as the neighbour list's: class c holds radii in (r_max / 2^(c+1), r_max / 2^c] (the last also all
  // smaller ones), each in a grid of cells one of its own largest diameters wide. One grid sized by the largest grain
  // put a whole bed of small grains in the cells around a large one: 159,000 disks and one of 40 diameters took 12 s
  // (0.2 s without it). With one class this is the single grid it was, visited in the same order. Each grain looks up
  // the larger classes' grids, not a large grain the smaller classes': that scans (2 R / r)^D cells or every grain of
  // the class.
  const SizeClasses sizes(*std::max_element(P.radius.begin(), P.radius.end()),
                          *std::min_element(P.radius.begin(), P.radius.end()));
  const int classes = sizes.count;
  std::vector<int> class_of(N);
  for (std::size_t i = 0; i < N; ++i) class_of[i] = sizes.of(P.radius[i]);

  struct Grid {
    std::array<long long, D> n{};
    Vec<D> cell;
    double rmax = 0;
    std::vector<std::size_t> members;   // in index order
    std::unordered_map<unsigned long long, std::vector<std::size_t>> cells;
  };
  std::vector<Grid> grids(classes);
  for (std::size_t i = 0; i < N; ++i) {
    Grid& g = grids[class_of[i]];
    g.rmax = std::max(g.rmax, P.radius[i]), g.members.push_back(i);
  }
  for (Grid& g : grids) {
    const double dmax = 2 * g.rmax;
    for (int a = 0; a < D; ++a) {   // periodic axes tiled exactly, so that cell indices wrap
      // At most 1e6 cells an axis (wider cells find the same pairs): a tiny grain's L / d in a large box (1e-30 in
      // 10) overflowed the integer it was converted to (found by fuzzing).
      g.n[a] = box.periodic[a] ? (long long)std::clamp(std::floor(box.length[a] / dmax), 1.0, 1e6) : 0;
      g.cell[a] = box.periodic[a] ? box.length[a] / double(g.n[a]) : dmax;
    }
  }
  // Unsigned: far cells of an open box wrap around (their keys may collide: more candidates, never a wrong pair).
  auto key = [&](const Grid& g, std::array<long long, D> c) {
    unsigned long long k = 0;
    for (int a = 0; a < D; ++a) {
      if (box.periodic[a]) c[a] = ((c[a] % g.n[a]) + g.n[a]) % g.n[a];
      k = k * 2000003ULL + static_cast<unsigned long long>(c[a] + 1000000);
    }
    return k;
  };
  auto coords = [&](const Grid& g, const Vec<D>& x) {
    std::array<long long, D> c;   // clamped: a particle far out of an open box shares an edge cell, never overflows
    for (int a = 0; a < D; ++a) c[a] = (long long)std::clamp(std::floor((x[a] - box.lower[a]) / g.cell[a]), -1e15, 1e15);
    return c;
  };
  for (Grid& g : grids)
    for (const std::size_t i : g.members) g.cells[key(g, coords(g, P.position[i]))].push_back(i);

  auto test = [&](std::size_t i, std::size_t j) {
    ++found.pairs_tested;
    const double d = box.minimum_image(P.position[j] - P.position[i]).norm();
    const double rmin_ij = std::min(P.radius[i], P.radius[j]);
    const double overlap = P.radius[i] + P.radius[j] - d;
    const std::size_t lo = std::min(i, j), hi = std::max(i, j);
    if (d == 0 && (!found.coincident || std::pair(lo, hi) < std::pair(found.same_i, found.same_j)))
      found.coincident = true, found.same_i = lo, found.same_j = hi;
    if (!(overlap > overlap_limit * rmin_ij)) return;
    ++found.deep;
    // Equally deep pairs: the lowest indices, as testing every pair in index order names them (the classes' grids
    // visit a large grain's pairs with smaller ones at the large grain, out of that order).
    const double ratio = overlap / rmin_ij;
    if (ratio > found.ratio || (ratio > 0 && ratio == found.ratio && std::pair(lo, hi) < std::pair(found.i, found.j)))
      found.i = lo, found.j = hi, found.overlap = overlap, found.ratio = ratio;
  };
  constexpr int neighbour_cells = D == 3 ? 27 : 9;
  std::vector<unsigned long long> keys;
  for (std::size_t i = 0; i < N; ++i) {
    const int own = class_of[i];
    // Each larger class, then its own: the 3^D cells around its own in the class's grid. It is no larger than any
    // grain of a larger class, so a pair that touches lies in neighbouring cells there; in its own class, the later
    // grains (each pair once).
    for (int b = 0; b <= own; ++b) {
      const Grid& g = grids[b];
      if (g.members.empty()) continue;
      const auto home = coords(g, P.position[i]);
      keys.clear();
      for (int m = 0; m < neighbour_cells; ++m) {
        auto c = home;
        for (int a = 0, r = m; a < D; ++a, r /= 3) c[a] += r % 3 - 1;
        keys.push_back(key(g, c));
      }
      // A narrow periodic box wraps several neighbours onto one cell: each cell once, each pair once.
      std::sort(keys.begin(), keys.end());
      keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
      for (const unsigned long long k : keys)
        if (const auto it = g.cells.find(k); it != g.cells.end())
          for (const std::size_t j : it->second)
            if (b < own || j > i) test(i, j);
    }
  }
  return found;
}

template InitialOverlaps find_initial_overlaps<2>(const Particles<2>&, const Box<2>&, double);
template InitialOverlaps find_initial_overlaps<3>(const Particles<3>&, const Box<3>&, double);

}  // namespace grains
