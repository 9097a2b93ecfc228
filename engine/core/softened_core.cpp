#include "core/softened_core.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "core/cell_table.hpp"

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
    // Each cell's members in one flat array, ascending within a cell (a counting sort by cell id).
    std::vector<Cell> home(N);
    std::vector<std::uint32_t> id(N);
    CellTable<D> table(N);
    for (std::size_t i = 0; i < N; ++i) home[i] = cell_of(x[i]), id[i] = table.insert(home[i]);
    std::vector<std::size_t> start(std::size_t(table.size()) + 1, 0), member(N);
    for (std::size_t i = 0; i < N; ++i) ++start[id[i] + 1];
    for (std::size_t c = 0; c < table.size(); ++c) start[c + 1] += start[c];
    {
      std::vector<std::size_t> fill(start.begin(), start.end() - 1);
      for (std::size_t i = 0; i < N; ++i) member[fill[id[i]]++] = i;
    }
    std::vector<Vec<D>> xs(N);   // the positions in that order: a cell's are read together, not from all over x
    for (std::size_t p = 0; p < N; ++p) xs[p] = x[member[p]];
    const double reach2 = reach * reach;
    // The pairs in the order the map of vectors visited them (i ascending, the 3^D cells in turn, j ascending in
    // each), so that every sum adds the same masses in the same order: the same bits as before.
    for (std::size_t i = 0; i < N; ++i) {
      const Vec<D> xi = x[i];
      Cell c;
      // every cell of the 3^D around home, j > i only: each pair once, counted for both
      for (int k = 0; k < (D == 3 ? 27 : 9); ++k) {
        for (int a = 0, rest = k; a < D; ++a, rest /= 3) c[a] = home[i][a] + (rest % 3 - 1);
        const std::uint32_t found = k == (D == 3 ? 13 : 4) ? id[i] : table.find(c);   // 13 (4): home itself
        if (found == CellTable<D>::none) continue;
        const std::size_t* const first = member.data() + start[found], * const end = member.data() + start[found + 1];
        for (const std::size_t* p = std::upper_bound(first, end, i); p != end; ++p) {
          const std::size_t j = *p;
          if ((xs[p - member.data()] - xi).squaredNorm() < reach2) within[i] += mass[j], within[j] += mass[i], ++count[i], ++count[j];
        }
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
