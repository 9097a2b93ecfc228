#include "analysis/softened_core.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "core/cell_hash.hpp"

namespace grains {

template <int D>
SoftenedCore densest_softened_core(const std::vector<Vec<D>>& x, const std::vector<double>& mass, double reach) {
  using Cell = std::array<std::int64_t, D>;
  const std::size_t N = x.size();
  SoftenedCore best;
  if (N == 0) return best;
  std::vector<double> within(mass.begin(), mass.end());   // each particle's own mass, then its neighbours'
  std::vector<std::size_t> count(N, 1);
  if (reach > 0 && std::isfinite(reach)) {
    auto cell_of = [&](const Vec<D>& p) {
      Cell c;   // clamped: a far-flung particle keeps a cell of its own without overflowing
      for (int a = 0; a < D; ++a) c[a] = std::int64_t(std::clamp(std::floor(p[a] / reach), -4e18, 4e18));
      return c;
    };
    std::unordered_map<Cell, std::vector<std::size_t>, CellHash<D>> cells;
    for (std::size_t i = 0; i < N; ++i) cells[cell_of(x[i])].push_back(i);
    const double reach2 = reach * reach;
    for (std::size_t i = 0; i < N; ++i) {
      const Cell home = cell_of(x[i]);
      Cell c;
      // every cell of the 3^D around home, j > i only: each pair once, counted for both
      for (int k = 0; k < (D == 3 ? 27 : 9); ++k) {
        for (int a = 0, rest = k; a < D; ++a, rest /= 3) c[a] = home[a] + (rest % 3 - 1);
        const auto found = cells.find(c);
        if (found == cells.end()) continue;
        for (const std::size_t j : found->second)
          if (j > i && (x[j] - x[i]).squaredNorm() < reach2) within[i] += mass[j], within[j] += mass[i], ++count[i], ++count[j];
      }
    }
  }
  for (std::size_t i = 0; i < N; ++i)
    if (count[i] > 1 && within[i] > best.mass) best = {within[i], count[i], i};
  return best;
}

template SoftenedCore densest_softened_core<2>(const std::vector<Vec<2>>&, const std::vector<double>&, double);
template SoftenedCore densest_softened_core<3>(const std::vector<Vec<3>>&, const std::vector<double>&, double);

}  // namespace grains
