// The candidate pairs of grains whose sizes may spread widely, by size classes (neighbours/size_classes.hpp: class c
// holds radii in (r_max / 2^(c+1), r_max / 2^c], the last also all smaller ones). Each class is in a grid of its own,
// cells 2 R_max(c) + gap wide. Each grain is paired with the grains of each larger class in the 3^D cells around its
// own in that class's grid, then with the later grains of its own class in the 3^D cells around its own: it is no
// larger than any grain of a larger class, so two grains closer than R_i + R_j + gap lie in neighbouring cells there;
// each pair comes once. With one class this is the single grid.
// One grid sized by the largest grain put a whole bed of small grains in the cells around a large one (159,000 disks
// and one of 40 diameters: 12 s, 0.2 s without it); a large grain searching the smaller classes' grids within its
// reach scanned (2 R / r)^D cells or every grain of the class (20,000 disks of radius 1 and 20,000 of 0.001 spread
// thin: 1.5 s, the single grid 0.04 s).
// The box's lower corner is the grids' origin; its periodic axes are tiled exactly (at most 1e6 cells an axis: wider
// cells find the same pairs) and wrap, a narrow box's neighbour cells visited once each; an open box's grains may
// spread over any range. A grid whose occupied cells span a small box (a cloud, an aggregate, a packing: up to 64
// cells a grain) holds them in a plain array over that box, else in a hashed table (core/cell_table.hpp); each cell's
// grains lie together in one array, ascending.
// Users: the starting-overlap check (protocols/initial_overlaps.cpp) and the cluster analysis (analysis/clusters.cpp),
// each measuring its candidates' distances its own way.
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/box.hpp"
#include "core/cell_table.hpp"
#include "core/vec.hpp"

namespace grains {

template <int D>
class SizeClassPairs {
 public:
  // x and radius are read, not copied: they must outlive the search. gap >= 0.
  SizeClassPairs(const std::vector<Vec<D>>& x, const std::vector<double>& radius, double gap, const Box<D>& box);

  // visit(i, j) once for each candidate pair: i ascending, at i its pairs with the larger classes' grains (largest
  // class first), then with its own class's grains j > i; the cells around i's in turn, j ascending in each.
  template <class Visit>
  void for_each_pair(Visit&& visit) const {
    const std::size_t N = x_.size();
    for (std::size_t i = 0; i < N; ++i) {
      const int own = class_of_[i];
      for (int b = 0; b <= own; ++b) {
        const Grid& g = grids_[b];
        if (g.member.empty()) continue;
        // The cells around i's on each axis: three, fewer where a periodic axis has only one or two (each once), and
        // in a plain array only those inside its box, as their parts of the array index.
        const Cell home = b == own ? home_[i] : cell_of(g, x_[i]);
        std::array<std::array<std::int64_t, 3>, D> along;
        std::array<int, D> count{};
        for (int a = 0; a < D; ++a) {
          const auto add = [&](std::int64_t c) {
            if (!g.dense) return void(along[a][count[a]++] = c);
            if (const std::uint64_t off = std::uint64_t(c - g.lo[a]); off < g.extent[a])   // below lo wraps: outside
              along[a][count[a]++] = std::int64_t(off * g.stride[a]);
          };
          const std::int64_t n = g.n[a];
          const auto wrap = [n](std::int64_t c) { return n == 0 ? c : ((c % n) + n) % n; };
          for (int k = -1; k <= 1 && k + 1 < (n == 0 ? 3 : n); ++k) add(wrap(home[a] + k));
        }
        if (count[0] == 0) continue;   // a plain array's box lies beside i's cells
        // The grains of cells id .. id + cells - 1.
        const auto visit_cells = [&](std::uint32_t id, int cells) {
          if (id == CellTable<D>::none) return;
          const std::uint32_t* const first = g.member.data() + g.start[id];
          const std::uint32_t* const end = g.member.data() + g.start[id + cells];
          if (b < own)
            for (const std::uint32_t* p = first; p != end; ++p) visit(i, std::size_t(*p));
          else
            for (const std::uint32_t* p = first; p != end; ++p)
              if (*p > i) visit(i, std::size_t(*p));
        };
        if (!g.dense) {
          around(along, count, count[0], [&](const Cell& c) { visit_cells(g.table.find(c), 1); });
        } else {
          // Consecutive cells along the first axis are consecutive in the array: one run of grains for the row.
          bool row = true;
          for (int k = 1; k < count[0]; ++k) row &= along[0][k] == along[0][k - 1] + 1;
          around(along, count, row ? 1 : count[0], [&](const Cell& c) {
            std::int64_t k = 0;
            for (int a = 0; a < D; ++a) k += c[a];
            visit_cells(std::uint32_t(k), row ? count[0] : 1);
          });
        }
      }
    }
  }

 private:
  using Cell = std::array<std::int64_t, D>;
  struct Grid {
    Vec<D> width;                      // the cells' edge on each axis
    std::array<std::int64_t, D> n{};   // cells along each periodic axis; 0 on an open one
    bool dense = false;
    Cell lo{};                         // dense: the occupied cells' box, from lo, extent[a] cells along axis a
    std::array<std::uint64_t, D> extent{}, stride{};   // the array index: sum of (c[a] - lo[a]) stride[a]
    CellTable<D> table{0};             // hashed: the occupied cells' ids
    std::vector<std::uint32_t> start;  // a cell's grains (by id, or dense index): member[start[id]] .. member[start[id + 1] - 1]
    std::vector<std::uint32_t> member;
  };
  // The cell's coordinates, not yet wrapped; clamped so that the conversion is defined (and a neighbour's index does
  // not overflow) for any finite x: grains further out than 1e15 cells share an edge cell, more candidates but never a
  // pair missed (on an open axis; on a periodic one such a position is no position within the box anyway).
  Cell cell_of(const Grid& g, const Vec<D>& p) const {
    Cell c;
    for (int a = 0; a < D; ++a) c[a] = std::int64_t(std::clamp(std::floor((p[a] - lower_[a]) / g.width[a]), -1e15, 1e15));
    return c;
  }
  // f(c) for each c with c[a] one of along[a][0 .. count[a] - 1] (on the first axis only the first `first` of them),
  // the first axis fastest.
  template <class F>
  static void around(const std::array<std::array<std::int64_t, 3>, D>& along, const std::array<int, D>& count, int first,
                     F&& f) {
    Cell c;
    if constexpr (D == 2) {
      for (int v = 0; v < count[1]; ++v)
        for (int w = 0; w < first; ++w) c = {along[0][w], along[1][v]}, f(c);
    } else {
      for (int u = 0; u < count[2]; ++u)
        for (int v = 0; v < count[1]; ++v)
          for (int w = 0; w < first; ++w) c = {along[0][w], along[1][v], along[2][u]}, f(c);
    }
  }
  const std::vector<Vec<D>>& x_;
  Vec<D> lower_;
  std::vector<std::uint8_t> class_of_;
  std::vector<Cell> home_;   // each grain's cell in its class's grid, wrapped
  std::vector<Grid> grids_;
};

extern template class SizeClassPairs<2>;
extern template class SizeClassPairs<3>;

}  // namespace grains
