#include "neighbours/neighbour_list.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include <omp.h>

namespace grains {
namespace {

// One uniform grid of cells holding the particles of one size class.
template <int D>
struct Grid {
  Vec<D> origin, cell;
  std::array<int, D> n{};
  std::vector<std::uint32_t> cell_start, members;   // counting-sorted particle indices per cell
  std::vector<Vec<D>> member_position;               // positions and radii in cell order: the
  std::vector<double> member_radius;                 // candidate loop then reads memory in sequence
  double max_radius = 0;

  int flat(const std::array<int, D>& c) const {
    int f = 0;
    for (int a = D - 1; a >= 0; --a) f = f * n[a] + c[a];
    return f;
  }
  std::array<int, D> coords(const Vec<D>& x) const {
    std::array<int, D> c;
    for (int a = 0; a < D; ++a) c[a] = std::clamp(int(std::floor((x[a] - origin[a]) / cell[a])), 0, n[a] - 1);
    return c;
  }
};

}  // namespace

template <int D>
void NeighbourList<D>::build(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const Box<D>& box, int threads) {
  const std::size_t N = x.size();
  // Size classes: class c holds radii in (r_max / 2^(c+1), r_max / 2^c]; class 0 is the largest.
  double rmax = N ? *std::max_element(radius.begin(), radius.end()) : 1.0;
  double rmin = N ? *std::min_element(radius.begin(), radius.end()) : 1.0;
  int classes = std::max(1, int(std::ceil(std::log2(rmax / rmin) - 1e-12)));
  classes = std::min(classes, 8);
  std::vector<int> klass(N);
  for (std::size_t i = 0; i < N; ++i)
    klass[i] = std::min(classes - 1, std::max(0, int(std::floor(std::log2(rmax / radius[i])))));

  Vec<D> lo = box.lower, hi = box.lower + box.length;
  for (int a = 0; a < D; ++a)
    if (!box.periodic[a] && N) {   // open axis: the grid spans the particles
      lo[a] = hi[a] = x[0][a];
      for (const auto& p : x) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
      hi[a] += 1e-9 * (1 + std::abs(hi[a]));
    }

  std::vector<Grid<D>> grids(classes);
  for (std::size_t i = 0; i < N; ++i) grids[klass[i]].max_radius = std::max(grids[klass[i]].max_radius, radius[i]);
  for (int c = 0; c < classes; ++c) {
    auto& g = grids[c];
    double want = 2 * g.max_radius + range_ + skin_;
    double cells = 1;
    for (int a = 0; a < D; ++a) {
      double extent = hi[a] - lo[a];
      g.n[a] = std::max(1, int(std::floor(extent / want)));
      if (!box.periodic[a]) g.n[a] = std::min(g.n[a], 1 << 20);
      cells *= g.n[a];
    }
    while (cells > 4.0 * N + 64) {   // sparse open systems: coarsen instead of allocating empty cells
      cells = 1;
      for (int a = 0; a < D; ++a) g.n[a] = std::max(1, g.n[a] / 2), cells *= g.n[a];
    }
    for (int a = 0; a < D; ++a) g.origin[a] = lo[a], g.cell[a] = std::max((hi[a] - lo[a]) / g.n[a], 1e-300);
    g.cell_start.assign(std::size_t(cells) + 1, 0);
  }
  std::vector<int> cell_of(N);
  for (std::size_t i = 0; i < N; ++i) {
    auto& g = grids[klass[i]];
    cell_of[i] = g.flat(g.coords(x[i]));
    ++g.cell_start[cell_of[i] + 1];
  }
  for (auto& g : grids) {
    std::partial_sum(g.cell_start.begin(), g.cell_start.end(), g.cell_start.begin());
    g.members.resize(g.cell_start.back());
  }
  {
    std::vector<std::vector<std::uint32_t>> fill(classes);
    for (int c = 0; c < classes; ++c) fill[c].assign(grids[c].cell_start.begin(), grids[c].cell_start.end() - 1);
    for (std::size_t i = 0; i < N; ++i) grids[klass[i]].members[fill[klass[i]][cell_of[i]]++] = std::uint32_t(i);
    for (auto& g : grids) {
      g.member_position.resize(g.members.size());
      g.member_radius.resize(g.members.size());
      for (std::size_t m = 0; m < g.members.size(); ++m)
        g.member_position[m] = x[g.members[m]], g.member_radius[m] = radius[g.members[m]];
    }
  }

  // Periodic image shifts, indexed by sum (k_a + 1) 3^a with k_a in {-1, 0, 1}.
  constexpr int images = D == 3 ? 27 : 9;
  shift.assign(images, Vec<D>::Zero());
  for (int s = 0; s < images; ++s)
    for (int a = 0, r = s; a < D; ++a, r /= 3) shift[s][a] = (r % 3 - 1) * box.length[a];

  struct Pair { std::uint32_t i, j; std::uint8_t img; };
  int nthreads = std::max(1, threads);
  std::vector<std::vector<Pair>> found(nthreads);
  const double reach_extra = range_ + skin_;

#pragma omp parallel num_threads(nthreads)
  {
    auto& mine = found[omp_get_thread_num()];
    mine.reserve(std::size_t(8 * N / nthreads) + 16);
#pragma omp for schedule(static)
    for (std::size_t p = 0; p < N; ++p) {
      const int cp = klass[p];
      const Vec<D> xp = x[p];
      const double rp = radius[p];
      for (int c = cp; c >= 0; --c) {   // own class and every larger class
        const auto& g = grids[c];
        auto home = g.coords(x[p]);
        std::array<std::array<int, 3>, D> axis_cells;
        std::array<int, D> axis_count;
        for (int a = 0; a < D; ++a) {   // neighbouring cells per axis, without duplicates
          int k = 0;
          for (int o = -1; o <= 1; ++o) {
            int v = home[a] + o;
            if (box.periodic[a]) v = (v % g.n[a] + g.n[a]) % g.n[a];
            else if (v < 0 || v >= g.n[a]) continue;
            bool dup = false;
            for (int q = 0; q < k; ++q) dup |= axis_cells[a][q] == v;
            if (!dup) axis_cells[a][k++] = v;
          }
          axis_count[a] = k;
        }
        std::array<int, D> idx{};
        for (;;) {
          std::array<int, D> cc;
          for (int a = 0; a < D; ++a) cc[a] = axis_cells[a][idx[a]];
          int f = g.flat(cc);
          for (std::uint32_t m = g.cell_start[f]; m < g.cell_start[f + 1]; ++m) {
            std::uint32_t q = g.members[m];
            if (c == cp && q <= p) continue;   // same class: each pair once
            Vec<D> r = g.member_position[m] - xp;
            int img = 0;
            for (int a = D - 1; a >= 0; --a) {   // positions are wrapped, so |r_a| < L_a
              int k = 0;
              if (box.periodic[a]) k = r[a] > 0.5 * box.length[a] ? -1 : (r[a] < -0.5 * box.length[a] ? 1 : 0);
              img = img * 3 + (k + 1);
              r[a] += k * box.length[a];
            }
            double cut = rp + g.member_radius[m] + reach_extra;
            if (r.squaredNorm() < cut * cut) {
              if (p < q) mine.push_back({std::uint32_t(p), q, std::uint8_t(img)});
              else mine.push_back({q, std::uint32_t(p), std::uint8_t(images - 1 - img)});   // reversed pair, negated shift
            }
          }
          int a = 0;
          while (a < D && ++idx[a] == axis_count[a]) idx[a++] = 0;
          if (a == D) break;
        }
      }
    }
  }

  // Keep the old rows to map history, then assemble CSR with rows sorted by partner.
  std::vector<std::uint32_t> old_start = std::move(start), old_partner = std::move(partner);
  start.assign(N + 1, 0);
  for (const auto& f : found)
    for (const auto& pr : f) ++start[pr.i + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  partner.resize(start[N]);
  image.resize(start[N]);
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (const auto& f : found)
      for (const auto& pr : f) {
        auto k = fill[pr.i]++;
        partner[k] = pr.j;
        image[k] = pr.img;
      }
  }
  previous_entry_.assign(partner.size(), -1);
  // Rows sorted by partner: pack (partner, image) into one integer and sort each row in place.
  std::vector<std::uint64_t> packed(partner.size());
  for (std::size_t k = 0; k < partner.size(); ++k) packed[k] = (std::uint64_t(partner[k]) << 8) | image[k];
#pragma omp parallel for num_threads(nthreads) schedule(static)
  for (std::size_t i = 0; i < N; ++i) {
    std::size_t b = start[i], e = start[i + 1];
    std::sort(packed.begin() + b, packed.begin() + e);
    for (std::size_t k = b; k < e; ++k) partner[k] = std::uint32_t(packed[k] >> 8), image[k] = std::uint8_t(packed[k] & 0xff);
    if (i + 1 < old_start.size()) {   // merge-walk against the previous row
      std::size_t o = old_start[i], oe = old_start[i + 1];
      for (std::size_t k = b; k < e; ++k) {
        while (o < oe && old_partner[o] < partner[k]) ++o;
        if (o < oe && old_partner[o] == partner[k]) previous_entry_[k] = std::int64_t(o);
      }
    }
  }
  reference_ = x;
  strain_since_build_.setOnes();
  list_reach_ = 2 * (radius.empty() ? 0.0 : *std::max_element(radius.begin(), radius.end())) + range_ + skin_;
  ++builds_;
}

template <int D>
bool NeighbourList<D>::stale(const std::vector<Vec<D>>& x) const {
  if (reference_.size() != x.size()) return true;
  const double strain = (strain_since_build_.array() - 1).abs().maxCoeff();
  const double allowance = 0.5 * (skin_ - strain * list_reach_);   // per particle
  if (allowance <= 0) return true;
  const double limit = allowance * allowance;
  for (std::size_t i = 0; i < x.size(); ++i)
    if ((x[i] - reference_[i]).squaredNorm() > limit) return true;
  return false;
}

template <int D>
void NeighbourList<D>::follow_cell(const Vec<D>& scale, const Box<D>& box) {
  constexpr int images = D == 3 ? 27 : 9;
  for (int s = 0; s < images; ++s)
    for (int a = 0, r = s; a < D; ++a, r /= 3) shift[s][a] = (r % 3 - 1) * box.length[a];
  for (auto& x : reference_) x = box.lower + (x - box.lower).cwiseProduct(scale);
  strain_since_build_ = strain_since_build_.cwiseProduct(scale);
}

template <int D>
void NeighbourList<D>::save(ByteWriter& w) const {
  w.put(range_), w.put(skin_), w.put(builds_);
  w.put_vector(start), w.put_vector(partner), w.put_vector(image), w.put_vector(shift), w.put_vector(reference_);
  w.put(strain_since_build_), w.put(list_reach_);
}

template <int D>
void NeighbourList<D>::load(ByteReader& r) {
  range_ = r.get<double>(), skin_ = r.get<double>(), builds_ = r.get<long>();
  r.get_vector(start), r.get_vector(partner), r.get_vector(image), r.get_vector(shift), r.get_vector(reference_);
  strain_since_build_ = r.get<Vec<D>>(), list_reach_ = r.get<double>();
  previous_entry_.assign(partner.size(), -1);
}

template class NeighbourList<2>;
template class NeighbourList<3>;

}  // namespace grains
