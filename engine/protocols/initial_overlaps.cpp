#include "protocols/initial_overlaps.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>
#include <vector>

namespace grains {

template <int D>
InitialOverlaps find_initial_overlaps(const Particles<D>& P, const Box<D>& box, double overlap_limit) {
  InitialOverlaps found;
  if (P.size() < 2) return found;
  const double dmax = 2 * *std::max_element(P.radius.begin(), P.radius.end());
  std::array<long long, D> n;
  Vec<D> cell;
  for (int a = 0; a < D; ++a) {   // periodic axes tiled exactly, so that cell indices wrap
    n[a] = box.periodic[a] ? std::max(1LL, (long long)std::floor(box.length[a] / dmax)) : 0;
    cell[a] = box.periodic[a] ? box.length[a] / double(n[a]) : dmax;
  }
  // Unsigned: far cells of an open box wrap around (their keys may collide: more candidates, never a wrong pair).
  auto key = [&](std::array<long long, D> c) {
    unsigned long long k = 0;
    for (int a = 0; a < D; ++a) {
      if (box.periodic[a]) c[a] = ((c[a] % n[a]) + n[a]) % n[a];
      k = k * 2000003ULL + static_cast<unsigned long long>(c[a] + 1000000);
    }
    return k;
  };
  auto coords = [&](const Vec<D>& x) {
    std::array<long long, D> c;   // clamped: a particle far out of an open box shares an edge cell, never overflows
    for (int a = 0; a < D; ++a) c[a] = (long long)std::clamp(std::floor((x[a] - box.lower[a]) / cell[a]), -1e15, 1e15);
    return c;
  };
  std::unordered_map<unsigned long long, std::vector<std::size_t>> grid;
  for (std::size_t i = 0; i < P.size(); ++i) grid[key(coords(P.position[i]))].push_back(i);
  constexpr int neighbour_cells = D == 3 ? 27 : 9;
  std::array<unsigned long long, neighbour_cells> keys;
  for (std::size_t i = 0; i < P.size(); ++i) {
    const auto home = coords(P.position[i]);
    for (int m = 0; m < neighbour_cells; ++m) {
      auto c = home;
      for (int a = 0, r = m; a < D; ++a, r /= 3) c[a] += r % 3 - 1;
      keys[m] = key(c);
    }
    // A narrow periodic box wraps several neighbours onto one cell: each cell once, each pair once.
    std::sort(keys.begin(), keys.end());
    const auto last = std::unique(keys.begin(), keys.end());
    for (auto k = keys.begin(); k != last; ++k) {
      const auto it = grid.find(*k);
      if (it == grid.end()) continue;
      for (const std::size_t j : it->second) {
        if (j <= i) continue;
        const double d = box.minimum_image(P.position[j] - P.position[i]).norm();
        const double rmin = std::min(P.radius[i], P.radius[j]);
        const double overlap = P.radius[i] + P.radius[j] - d;
        if (d == 0 && !found.coincident) found.coincident = true, found.same_i = i, found.same_j = j;
        if (!(overlap > overlap_limit * rmin)) continue;
        ++found.deep;
        if (overlap / rmin > found.ratio) found.i = i, found.j = j, found.overlap = overlap, found.ratio = overlap / rmin;
      }
    }
  }
  return found;
}

template InitialOverlaps find_initial_overlaps<2>(const Particles<2>&, const Box<2>&, double);
template InitialOverlaps find_initial_overlaps<3>(const Particles<3>&, const Box<3>&, double);

}  // namespace grains
