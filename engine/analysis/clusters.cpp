#include "analysis/clusters.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "core/cell_hash.hpp"
#include "neighbours/size_classes.hpp"

namespace grains {

namespace {

struct UnionFind {
  std::vector<int> parent, size;
  explicit UnionFind(std::size_t n) : parent(n), size(n, 1) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];   // path halving
    return i;
  }
  void unite(int a, int b) {
    a = find(a), b = find(b);
    if (a == b) return;
    if (size[a] < size[b]) std::swap(a, b);
    parent[b] = a, size[a] += size[b];
  }
};

ClusterStats relabel(UnionFind& uf, const std::vector<double>& mass);

// Sizes spread over more than a factor 2: size classes as the neighbour list's (class c holds radii in
// (r_max / 2^(c+1), r_max / 2^c], the last also all smaller ones), each in a hashed grid of cells 2 R_max(c) + tol
// wide. Each grain is linked with the later grains of its own class in the 3^D cells around its own, and with the
// grains of each larger class in the 3^D cells around its own in that class's grid: it is no larger than any of them,
// so a linked pair lies in neighbouring cells there. One grid of cells 2 R_max + tol wide put a whole cloud of small
// grains in the cells around one large grain: 40,000 spheres and one of 20 diameters took 3.5 s an analysis (0.04 s
// without it). A large grain does not search the smaller classes' grids within its reach instead: that scans
// (2 R / r)^D cells or every grain of the class.
template <int D>
void link_by_size_class(const std::vector<Vec<D>>& x, const std::vector<double>& radius, double tol, double rmax,
                        double rmin, UnionFind& uf, std::size_t& tested) {
  using Cell = std::array<std::int64_t, D>;
  const std::size_t N = x.size();
  tol = std::max(0.0, tol);
  const SizeClasses sizes(rmax, rmin);
  const int classes = sizes.count;
  struct Grid {
    double rmax = 0, h = 0;
    std::vector<int> members;   // in index order
    std::unordered_map<Cell, std::vector<int>, CellHash<D>> cells;
  };
  std::vector<Grid> grids(classes);
  std::vector<int> class_of(N);
  for (std::size_t i = 0; i < N; ++i) {
    class_of[i] = sizes.of(radius[i]);
    Grid& g = grids[class_of[i]];
    g.rmax = std::max(g.rmax, radius[i]), g.members.push_back(int(i));
  }
  auto cell_of = [](const Vec<D>& p, double h) {
    Cell c;   // clamped as in find_clusters
    for (int a = 0; a < D; ++a) c[a] = std::int64_t(std::clamp(std::floor(p[a] / h), -4e18, 4e18));
    return c;
  };
  for (Grid& g : grids) {
    g.h = 2 * g.rmax + tol;
    for (const int i : g.members) g.cells[cell_of(x[i], g.h)].push_back(i);
  }
  auto link = [&](int i, int j) {
    ++tested;
    const double reach = radius[i] + radius[j] + tol;
    if ((x[j] - x[i]).squaredNorm() < reach * reach) uf.unite(i, j);
  };
  constexpr int stencil = D == 3 ? 27 : 9;
  for (std::size_t i = 0; i < N; ++i)
    for (int b = 0; b <= class_of[i]; ++b) {   // the larger classes', then its own (there, the later grains)
      const Grid& g = grids[b];
      if (g.members.empty()) continue;
      const Cell home = cell_of(x[i], g.h);
      for (int s = 0; s < stencil; ++s) {
        Cell n = home;
        for (int a = 0, r = s; a < D; ++a, r /= 3) n[a] += r % 3 - 1;
        if (const auto it = g.cells.find(n); it != g.cells.end())
          for (const int j : it->second)
            if (b < class_of[i] || j > int(i)) link(int(i), j);
      }
    }
}

}  // namespace

template <int D>
ClusterStats find_clusters(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const std::vector<double>& mass,
                           double tol) {
  ClusterStats st;
  const std::size_t N = x.size();
  if (N == 0) return st;
  const double rmax = *std::max_element(radius.begin(), radius.end());
  const double rmin = *std::min_element(radius.begin(), radius.end());
  using Cell = std::array<std::int64_t, D>;
  UnionFind uf(N);
  if (rmax > 2 * rmin) {
    std::size_t tested = 0;
    link_by_size_class<D>(x, radius, tol, rmax, rmin, uf, tested);
    ClusterStats out = relabel(uf, mass);
    out.pairs_tested = tested;
    return out;
  }
  const double h = 2 * rmax + std::max(0.0, tol);   // any linked pair lies in neighbouring cells
  auto cell_of = [&](const Vec<D>& p) {
    Cell c;
    // Clamped so that the conversion is defined (and a neighbour's index does not overflow) for any finite x.
    for (int a = 0; a < D; ++a) c[a] = std::int64_t(std::clamp(std::floor(p[a] / h), -4e18, 4e18));
    return c;
  };
  // Cell -> first particle; next[i] chains the particles of one cell. Where the occupied cells' bounding
  // box is small (a cloud, an aggregate: up to 64 cells a particle), the heads are a plain array over it;
  // else (a few grains far out) a hash map. Both give the same chains, so the same unions in the same order.
  Cell lo, hi;
  lo.fill(std::numeric_limits<std::int64_t>::max()), hi.fill(std::numeric_limits<std::int64_t>::min());
  std::vector<Cell> cell(N);
  for (std::size_t i = 0; i < N; ++i) {
    cell[i] = cell_of(x[i]);
    for (int a = 0; a < D; ++a) lo[a] = std::min(lo[a], cell[i][a]), hi[a] = std::max(hi[a], cell[i][a]);
  }
  double cells = 1;
  for (int a = 0; a < D; ++a) cells *= double(hi[a]) - double(lo[a]) + 3;   // a margin of one cell each side
  std::vector<int> next(N, -1);
  constexpr int stencil = D == 3 ? 27 : 9;
  std::size_t tested = 0;
  // Each grain i against the later grains of its neighbour cells; first_in(cell): the cell's first grain (-1: none).
  const auto scan = [&](auto&& first_in) {
    for (std::size_t i = 0; i < N; ++i)
      for (int s = 0; s < stencil; ++s) {
        Cell n = cell[i];
        for (int a = 0, r = s; a < D; ++a, r /= 3) n[a] += r % 3 - 1;
        for (int j = first_in(n); j >= 0; j = next[j]) {
          if (j <= int(i)) continue;
          ++tested;
          const double reach = radius[i] + radius[j] + tol;
          if ((x[j] - x[i]).squaredNorm() < reach * reach) uf.unite(int(i), j);
        }
      }
  };
  if (cells <= 64.0 * double(N) + 1e4) {
    std::array<std::int64_t, D> stride;
    std::int64_t size = 1;
    for (int a = 0; a < D; ++a) stride[a] = size, size *= hi[a] - lo[a] + 3;
    const auto index = [&](const Cell& c) {
      std::int64_t k = 0;
      for (int a = 0; a < D; ++a) k += (c[a] - lo[a] + 1) * stride[a];
      return k;
    };
    std::vector<int> head(std::size_t(size), -1);
    for (std::size_t i = 0; i < N; ++i) {
      int& h = head[std::size_t(index(cell[i]))];
      next[i] = h, h = int(i);
    }
    scan([&](const Cell& c) { return head[std::size_t(index(c))]; });
  } else {
    std::unordered_map<Cell, int, CellHash<D>> head;
    head.reserve(N);
    for (std::size_t i = 0; i < N; ++i) {
      auto [it, inserted] = head.try_emplace(cell[i], int(i));
      if (!inserted) next[i] = it->second, it->second = int(i);
    }
    scan([&](const Cell& c) {
      auto it = head.find(c);
      return it == head.end() ? -1 : it->second;
    });
  }
  ClusterStats out = relabel(uf, mass);
  out.pairs_tested = tested;
  return out;
}

namespace {

// Roots relabelled 0 .. N_c-1 in order of first appearance; masses summed per cluster. The labels depend on the
// partition alone, not on the order of the unions.
ClusterStats relabel(UnionFind& uf, const std::vector<double>& mass) {
  ClusterStats st;
  const std::size_t N = mass.size();
  st.label.assign(N, -1);
  std::vector<int> root_label(N, -1);
  std::vector<double> cluster_mass;
  double total = 0;
  for (std::size_t i = 0; i < N; ++i) {
    const int r = uf.find(int(i));
    if (root_label[r] < 0) root_label[r] = int(cluster_mass.size()), cluster_mass.push_back(0);
    st.label[i] = root_label[r];
    cluster_mass[root_label[r]] += mass[i];
    total += mass[i];
  }
  st.count = cluster_mass.size();
  st.largest = int(std::max_element(cluster_mass.begin(), cluster_mass.end()) - cluster_mass.begin());
  st.largest_fraction = total > 0 ? cluster_mass[st.largest] / total : 0;
  return st;
}

}  // namespace

template ClusterStats find_clusters<2>(const std::vector<Vec<2>>&, const std::vector<double>&, const std::vector<double>&, double);
template ClusterStats find_clusters<3>(const std::vector<Vec<3>>&, const std::vector<double>&, const std::vector<double>&, double);

}  // namespace grains
