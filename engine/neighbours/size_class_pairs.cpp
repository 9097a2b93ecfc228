#include "neighbours/size_class_pairs.hpp"

#include <cmath>
#include <limits>

#include "neighbours/size_classes.hpp"

namespace grains {

template <int D>
SizeClassPairs<D>::SizeClassPairs(const std::vector<Vec<D>>& x, const std::vector<double>& radius, double gap,
                                  const Box<D>& box)
    : x_(x), lower_(box.lower), class_of_(x.size()) {
  const std::size_t N = x.size();
  if (N == 0) return;
  const SizeClasses sizes(*std::max_element(radius.begin(), radius.end()), *std::min_element(radius.begin(), radius.end()));
  grids_.resize(sizes.count);
  std::vector<std::size_t> members(sizes.count, 0);
  std::vector<double> rmax(sizes.count, 0);
  for (std::size_t i = 0; i < N; ++i) {
    const int c = sizes.of(radius[i]);
    class_of_[i] = std::uint8_t(c), ++members[c], rmax[c] = std::max(rmax[c], radius[i]);
  }
  for (int c = 0; c < sizes.count; ++c) {
    Grid& g = grids_[c];
    const double width = 2 * rmax[c] + gap;
    for (int a = 0; a < D; ++a) {
      // A tiny grain's L / d in a large box (1e-30 in 10) overflowed the integer it was converted to (found by fuzzing).
      g.n[a] = box.periodic[a] ? std::int64_t(std::clamp(std::floor(box.length[a] / width), 1.0, 1e6)) : 0;
      g.width[a] = box.periodic[a] ? box.length[a] / double(g.n[a]) : width;
    }
  }
  // Each grain's cell, wrapped, and each grid's occupied box.
  std::vector<Cell>& cell = home_;
  cell.resize(N);
  std::vector<Cell> lo(sizes.count), hi(sizes.count);
  for (int c = 0; c < sizes.count; ++c)
    lo[c].fill(std::numeric_limits<std::int64_t>::max()), hi[c].fill(std::numeric_limits<std::int64_t>::min());
  for (std::size_t i = 0; i < N; ++i) {
    const int k = class_of_[i];
    const Grid& g = grids_[k];
    cell[i] = cell_of(g, x[i]);
    for (int a = 0; a < D; ++a) {
      if (g.n[a] > 0) cell[i][a] = ((cell[i][a] % g.n[a]) + g.n[a]) % g.n[a];
      lo[k][a] = std::min(lo[k][a], cell[i][a]), hi[k][a] = std::max(hi[k][a], cell[i][a]);
    }
  }
  for (int c = 0; c < sizes.count; ++c) {
    Grid& g = grids_[c];
    if (members[c] == 0) continue;
    double cells = 1;
    for (int a = 0; a < D; ++a) cells *= double(hi[c][a]) - double(lo[c][a]) + 1;
    g.dense = cells <= 64.0 * double(members[c]) + 1e4 && cells < 4e9;   // ids below CellTable::none
    if (g.dense) {
      g.lo = lo[c];
      std::uint64_t stride = 1;
      for (int a = 0; a < D; ++a)
        g.extent[a] = std::uint64_t(hi[c][a] - lo[c][a]) + 1, g.stride[a] = stride, stride *= g.extent[a];
      g.start.assign(std::size_t(cells) + 1, 0);
    } else {
      g.table = CellTable<D>(members[c]);
    }
  }
  // Each grid's grains grouped by cell: a counting sort by cell id (or dense index), so ascending within a cell.
  std::vector<std::uint32_t> id(N);
  for (std::size_t i = 0; i < N; ++i) {
    Grid& g = grids_[class_of_[i]];
    if (g.dense) {
      std::uint64_t k = 0;
      for (int a = 0; a < D; ++a) k += std::uint64_t(cell[i][a] - g.lo[a]) * g.stride[a];
      id[i] = std::uint32_t(k);
    } else {
      id[i] = g.table.insert(cell[i]);
    }
  }
  for (Grid& g : grids_)
    if (!g.dense) g.start.assign(std::size_t(g.table.size()) + 1, 0);
  for (std::size_t i = 0; i < N; ++i) ++grids_[class_of_[i]].start[id[i]];
  for (Grid& g : grids_) {   // each cell's end, then (filled from the last grain back) its start
    for (std::size_t k = 1; k < g.start.size(); ++k) g.start[k] += g.start[k - 1];
    g.member.resize(g.start.empty() ? 0 : g.start.back());
  }
  for (std::size_t i = N; i-- > 0;) {
    Grid& g = grids_[class_of_[i]];
    g.member[--g.start[id[i]]] = std::uint32_t(i);
  }
}

template class SizeClassPairs<2>;
template class SizeClassPairs<3>;

}  // namespace grains
