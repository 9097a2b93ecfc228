#include "neighbours/neighbour_list.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <limits>
#include <numeric>

#include <omp.h>

#include "interactions/pair_filter.hpp"   // avx512(): whether the AVX-512 pieces run
#include "core/cell_hash.hpp"
#include "neighbours/candidate_test.hpp"
#include "neighbours/size_classes.hpp"

namespace grains {

template <int D>
int NeighbourList<D>::Grid::flat(const std::array<int, D>& c) const {
  int f = 0;
  for (int a = D - 1; a >= 0; --a) f = f * n[a] + c[a];
  return f;
}

template <int D>
std::array<int, D> NeighbourList<D>::Grid::coords(const Vec<D>& x) const {
  std::array<int, D> c;   // clamped first, so truncation is the floor (and needs no libm call)
  for (int a = 0; a < D; ++a) c[a] = int(std::clamp((x[a] - origin[a]) * inverse_cell[a], 0.0, double(n[a] - 1)));
  return c;
}

template <int D>
std::array<std::int64_t, D> NeighbourList<D>::Grid::key(const Vec<D>& x) const {
  std::array<std::int64_t, D> k;   // open axes: unbounded but for a clamp far inside int64 (so k +- 1 cannot overflow)
  for (int a = 0; a < D; ++a)
    k[a] = std::int64_t(std::clamp((x[a] - origin[a]) * inverse_cell[a], 0.0, n[a] > 0 ? double(n[a] - 1) : 0x1p62));
  return k;
}

// Blocks of eight cells along x share a hash and take consecutive buckets: the three cells of a row next
// to a particle's are mostly one run of memory.
template <int D>
std::uint32_t NeighbourList<D>::Grid::bucket(const std::array<std::int64_t, D>& k) const {
  auto block = k;
  block[0] >>= 3;
  return std::uint32_t(((CellHash<D>{}(block) << 3) | std::uint64_t(k[0] & 7)) & bucket_mask);
}

namespace {

// A coarsened dense grid is made hashed when the particles searching it meet, in their own cell alone, more
// than this many of its members each on average (their candidates: about 27 / 2 times as many).
constexpr double crowded = 12;

// A particle's view of one grid's slots, for the candidate test.
template <int D, class Grid>
candidate_test::Probe<D> make_probe(const Grid& g, std::uint32_t p, const Vec<D>& xp, double rp, double reach_extra,
                                    const Box<D>& box) {
  candidate_test::Probe<D> probe;
  for (int a = 0; a < D; ++a) {
    probe.x[a] = g.member_x[a].data();
    probe.xp[a] = xp[a];
    // Minimum image without a branch on the axis kind: open axes never shift.
    probe.half[a] = box.periodic[a] ? 0.5 * box.length[a] : std::numeric_limits<double>::infinity();
    probe.period[a] = box.periodic[a] ? box.length[a] : 0.0;
  }
  probe.radius = g.member_radius.data(), probe.member = g.members.data();
  probe.p = p, probe.rp = rp, probe.reach_extra = reach_extra;
  return probe;
}

// Tests slots [b, e) (b < e), appending the finds to `out`.
template <int D, class Found>
void test_run(const candidate_test::Probe<D>& probe, std::uint32_t b, std::uint32_t e, bool wraps, bool wide, Found& out,
              std::size_t& used) {
  out.examined += e - b;
  // Every candidate may be written at the end of `out`, which only advances on a hit.
  if (used + (e - b) + candidate_test::slack > out.i.size()) {
    const std::size_t size = std::max(2 * out.i.size(), used + (e - b) + candidate_test::slack);
    out.i.resize(size), out.j.resize(size), out.image.resize(size);
  }
  const candidate_test::Finds finds{out.i.data(), out.j.data(), out.image.data()};
  used = wide ? candidate_test::test_avx512<D>(probe, b, e, wraps, finds, used)
              : candidate_test::test_portable<D>(probe, b, e, wraps, finds, used);
}

}  // namespace

// Candidates of particle p (position xp, radius rp) in grid g: the 3^D cells around its own, each
// visited once (a periodic axis of fewer than three cells has repeats), read as runs of cells that
// are consecutive along x (consecutive in memory too), each run tested by candidate_test (`wide`: its
// AVX-512 build). Slots below `first` are skipped: within its own grid a particle only looks at the
// slots after its own, so each pair is found once.
template <int D>
void NeighbourList<D>::search(const Grid& g, std::uint32_t first, std::uint32_t p, const Vec<D>& xp, double rp,
                              const Box<D>& box, bool wide, Found& out, std::size_t& used) const {
  if (g.hashed) return search_hashed(g, first, make_probe(g, p, xp, rp, range_ + skin_, box), xp, box, wide, out, used);
  const auto home = g.coords(xp);
  std::array<std::array<int, 3>, D> cells;
  std::array<int, D> count;
  bool wraps = false;   // some neighbour cell lies across a periodic boundary
  for (int a = 0; a < D; ++a) {
    int k = 0;
    for (int o = -1; o <= 1; ++o) {
      int v = home[a] + o;
      if (box.periodic[a]) {
        wraps |= v < 0 || v >= g.n[a];
        v = v < 0 ? v + g.n[a] : (v >= g.n[a] ? v - g.n[a] : v);
      }
      else if (v < 0 || v >= g.n[a]) continue;
      bool repeat = false;
      for (int q = 0; q < k; ++q) repeat |= cells[a][q] == v;
      if (!repeat) cells[a][k++] = v;
    }
    count[a] = k;
  }
  // Runs along x: sort the (at most three) cells, then merge neighbours.
  std::array<int, 3> run_lo, run_hi;
  int runs = 0;
  {
    auto& c = cells[0];
    for (int q = 1; q < count[0]; ++q)
      for (int h = q; h > 0 && c[h - 1] > c[h]; --h) std::swap(c[h - 1], c[h]);
    for (int q = 0; q < count[0]; ++q)
      if (runs > 0 && c[q] == run_hi[runs - 1] + 1) run_hi[runs - 1] = c[q];
      else run_lo[runs] = run_hi[runs] = c[q], ++runs;
  }
  const auto probe = make_probe(g, p, xp, rp, range_ + skin_, box);
  std::array<int, D> idx{}, cc{};
  for (;;) {
    for (int a = 1; a < D; ++a) cc[a] = cells[a][idx[a]];
    for (int u = 0; u < runs; ++u) {
      cc[0] = run_lo[u];
      const int f = g.flat(cc);
      const std::uint32_t b = std::max(g.cell_start[f], first), e = g.cell_start[f + run_hi[u] - run_lo[u] + 1];
      if (b < e) test_run(probe, b, e, wraps, wide, out, used);
    }
    int a = 1;
    while (a < D && ++idx[a] == count[a]) idx[a++] = 0;
    if (a == D) break;
  }
}

// The hashed grid's version: the 3^D cells around p's own (periodic axes wrapped, repeats dropped), each
// cell's bucket scanned once (cells sharing a bucket give it once; the bucket's other cells' members are
// candidates the distance test turns down), runs of consecutive buckets read as one.
template <int D>
void NeighbourList<D>::search_hashed(const Grid& g, std::uint32_t first, const candidate_test::Probe<D>& probe,
                                     const Vec<D>& xp, const Box<D>& box, bool wide, Found& out, std::size_t& used) const {
  const auto home = g.key(xp);
  std::array<std::array<std::int64_t, 3>, D> cells;
  std::array<int, D> count;
  bool wraps = false;
  for (int a = 0; a < D; ++a) {
    int k = 0;
    for (int o = -1; o <= 1; ++o) {
      std::int64_t v = home[a] + o;
      if (box.periodic[a]) {
        wraps |= v < 0 || v >= g.n[a];
        v = v < 0 ? v + g.n[a] : (v >= g.n[a] ? v - g.n[a] : v);
      }
      bool repeat = false;
      for (int q = 0; q < k; ++q) repeat |= cells[a][q] == v;
      if (!repeat) cells[a][k++] = v;
    }
    count[a] = k;
  }
  std::array<std::uint32_t, D == 3 ? 27 : 9> buckets;
  int nb = 0;
  std::array<int, D> idx{};
  std::array<std::int64_t, D> c;
  for (;;) {
    for (int a = 0; a < D; ++a) c[a] = cells[a][idx[a]];
    buckets[nb++] = g.bucket(c);
    int a = 0;
    while (a < D && ++idx[a] == count[a]) idx[a++] = 0;
    if (a == D) break;
  }
  std::sort(buckets.begin(), buckets.begin() + nb);
  nb = int(std::unique(buckets.begin(), buckets.begin() + nb) - buckets.begin());
  for (int q = 0; q < nb;) {
    int r = q + 1;
    while (r < nb && buckets[r] == buckets[r - 1] + 1) ++r;
    const std::uint32_t b = std::max(g.cell_start[buckets[q]], first), e = g.cell_start[buckets[r - 1] + 1];
    if (b < e) test_run(probe, b, e, wraps, wide, out, used);
    q = r;
  }
}

template <int D>
void NeighbourList<D>::build(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const Box<D>& box, int threads) {
  const std::size_t N = x.size();
  if (N >= std::numeric_limits<std::uint32_t>::max())
    throw std::runtime_error("neighbour list: " + std::to_string(N) + " particles, more than its 32-bit indices hold");
  const double rmax = N ? *std::max_element(radius.begin(), radius.end()) : 1.0;
  const SizeClasses sizes(rmax, N ? *std::min_element(radius.begin(), radius.end()) : 1.0);
  const int classes = sizes.count;
  class_of_.assign(N, 0);
  if (classes > 1)
    for (std::size_t i = 0; i < N; ++i) class_of_[i] = std::uint8_t(sizes.of(radius[i]));

  Vec<D> lo = box.lower, hi = box.lower + box.length;
  for (int a = 0; a < D; ++a)
    if (!box.periodic[a] && N) {   // open axis: the grid spans the particles
      lo[a] = hi[a] = x[0][a];
      for (const auto& p : x) lo[a] = std::min(lo[a], p[a]), hi[a] = std::max(hi[a], p[a]);
      // Widened far above the coordinates' rounding, in the scene's lengths (a diameter, not 1: an absolute
      // pad moved the cells, and the order of the pairs with them, when the same scene was written in
      // smaller units).
      hi[a] += 1e-9 * (2 * rmax + std::abs(hi[a]));
    }

  grids_.resize(classes);
  for (auto& g : grids_) g.max_radius = 0;
  for (std::size_t i = 0; i < N; ++i) grids_[class_of_[i]].max_radius = std::max(grids_[class_of_[i]].max_radius, radius[i]);
  // Dense grids first. One that had to be coarsened to the cell budget (an open box whose particles spread
  // thin) may have put most of them into a few cells (a grain far from the rest: N^2 candidates); such a
  // grid, told by its crowding (the sum of its cells' squared counts, which bounds the candidates over 27),
  // is made a hashed grid of uncoarsened cells. Grids not crowded stay dense: their lists are unchanged.
  const double budget = 4.0 * N + 64;
  const bool all_periodic = std::all_of(box.periodic.begin(), box.periodic.end(), [](bool p) { return p; });
  std::array<double, 9> hash_cell{};   // per class: the uncoarsened cell size, if coarsened in an open box
  for (int c = 0; c < classes; ++c) {
    auto& g = grids_[c];
    g.hashed = false;
    // Cells no smaller than the largest reach in the class (with a margin for the rounding of coords()).
    const double want = (2 * g.max_radius + range_ + skin_) * (1 + 1e-9);
    double cells = 1, open_extent = 0;
    for (int a = 0; a < D; ++a) {
      double extent = hi[a] - lo[a];
      if (!box.periodic[a]) open_extent = std::max(open_extent, extent);
      // clamped in floating point first: particles flung apart (1e300, or inf after the subtraction) give
      // one cell, not an overflowing conversion
      g.n[a] = int(std::clamp(std::floor(extent / want), 1.0, box.periodic[a] ? 1e9 : double(1 << 20)));
      cells *= g.n[a];
    }
    // Hashed cells wider by what the keys' rounding may move a grain (2^-52 of its distance from the origin, in
    // the subtraction and the product), so that grains within reach still fall in neighbouring cells: a grain
    // 3e15 reaches out had cost pairs. Beyond ~1e15 reaches the cells widen with the extent (exact, not linear).
    if (cells > budget && !all_periodic && std::isfinite(open_extent)) hash_cell[c] = want + open_extent * 0x1p-50;
    while (cells > budget) {   // sparse open systems: coarsen instead of allocating empty cells
      cells = 1;
      for (int a = 0; a < D; ++a) g.n[a] = std::max(1, g.n[a] / 2), cells *= g.n[a];
    }
    // the extent bounded above too: an overflowing one (inf) would make inverse_cell 0 and coords() NaN
    for (int a = 0; a < D; ++a)
      g.origin[a] = lo[a], g.inverse_cell[a] = g.n[a] / std::clamp(hi[a] - lo[a], 1e-300, std::numeric_limits<double>::max());
    g.cell_start.assign(std::size_t(cells) + 1, 0);
  }
  cell_of_.resize(N);
  for (std::size_t i = 0; i < N; ++i) {
    auto& g = grids_[class_of_[i]];
    cell_of_[i] = std::uint32_t(g.flat(g.coords(x[i])));
    ++g.cell_start[cell_of_[i] + 1];
  }
  for (int c = 0; c < classes; ++c) {
    auto& g = grids_[c];
    if (hash_cell[c] == 0) continue;
    // The particles that search this grid (its own and those of the smaller classes) per cell, and the
    // candidates they meet in their own cell.
    fill_.assign(g.cell_start.begin() + 1, g.cell_start.end());
    for (std::size_t i = 0; i < N; ++i)
      if (class_of_[i] > c) ++fill_[g.flat(g.coords(x[i]))];
    double visits = 0, crowding = 0;
    for (std::size_t f = 0; f < fill_.size(); ++f) visits += fill_[f], crowding += double(g.cell_start[f + 1]) * fill_[f];
    if (crowding <= crowded * visits + 64) continue;
    const double members = std::accumulate(g.cell_start.begin(), g.cell_start.end(), 0.0);
    g.hashed = true;   // periodic axes keep their cells
    std::uint64_t buckets = 64;
    while (buckets < 2 * members) buckets *= 2;
    g.bucket_mask = buckets - 1;
    for (int a = 0; a < D; ++a) {
      if (box.periodic[a]) g.n[a] = int(std::clamp(std::floor(box.length[a] / hash_cell[c]), 1.0, 1e9)), g.inverse_cell[a] = g.n[a] / box.length[a];
      else g.n[a] = 0, g.inverse_cell[a] = 1 / hash_cell[c];
    }
    g.cell_start.assign(buckets + 1, 0);
    for (std::size_t i = 0; i < N; ++i)
      if (class_of_[i] == c) cell_of_[i] = g.bucket(g.key(x[i])), ++g.cell_start[cell_of_[i] + 1];
  }
  // Visiting order: class 0's members in cell order, then class 1's, ... (visit_start[c] = first visit of class c).
  std::array<std::size_t, 9> visit_start{};
  for (int c = 0; c < classes; ++c) {
    auto& g = grids_[c];
    std::partial_sum(g.cell_start.begin(), g.cell_start.end(), g.cell_start.begin());
    g.members.resize(g.cell_start.back());
    for (auto& xa : g.member_x) xa.resize(g.members.size());
    g.member_radius.resize(g.members.size());
    visit_start[c + 1] = visit_start[c] + g.members.size();
  }
  for (int c = 0; c < classes; ++c) {
    auto& g = grids_[c];
    fill_.assign(g.cell_start.begin(), g.cell_start.end() - 1);
    for (std::size_t i = 0; i < N; ++i)
      if (class_of_[i] == c) {
        const auto m = fill_[cell_of_[i]]++;
        g.members[m] = std::uint32_t(i), g.member_radius[m] = radius[i];
        for (int a = 0; a < D; ++a) g.member_x[a][m] = x[i][a];
      }
  }

  // Periodic image shifts, indexed by sum (k_a + 1) 3^a with k_a in {-1, 0, 1}.
  constexpr int images = D == 3 ? 27 : 9;
  shift.assign(images, Vec<D>::Zero());
  for (int s = 0; s < images; ++s)
    for (int a = 0, r = s; a < D; ++a, r /= 3) shift[s][a] = (r % 3 - 1) * box.length[a];

  // Each thread takes a contiguous block of visits, so concatenating the threads' finds in thread
  // order gives the same sequence for any thread count.
  const int nthreads = std::max(1, threads);
  found_.resize(nthreads);
  found_count_.assign(nthreads, 0);
  const bool wide = pair_filter::avx512();
#pragma omp parallel num_threads(nthreads)
  {
    auto& mine = found_[omp_get_thread_num()];
    mine.examined = 0;
    std::size_t used = 0;
#pragma omp for schedule(static)
    for (std::size_t v = 0; v < N; ++v) {
      int c = 0;
      while (v >= visit_start[c + 1]) ++c;
      const auto& g = grids_[c];
      const auto m = std::uint32_t(v - visit_start[c]);
      const std::uint32_t p = g.members[m];
      Vec<D> xp;
      for (int a = 0; a < D; ++a) xp[a] = g.member_x[a][m];
      const double rp = g.member_radius[m];
      search(g, m + 1, p, xp, rp, box, wide, mine, used);   // own class: the slots after p's
      for (int larger = c - 1; larger >= 0; --larger) search(grids_[larger], 0, p, xp, rp, box, wide, mine, used);
    }
    found_count_[omp_get_thread_num()] = used;
  }

  candidates_examined_ = 0;
  std::size_t pairs = 0;
  for (int t = 0; t < nthreads; ++t) candidates_examined_ += found_[t].examined, pairs += found_count_[t];
  // Row starts and partners are 32-bit: refused rather than wrapped.
  if (pairs > std::numeric_limits<std::uint32_t>::max())
    throw std::runtime_error("neighbour list: " + std::to_string(N) + " particles have " + std::to_string(pairs) +
                             " pairs within reach, more than the 4294967295 its 32-bit rows hold");

  // CSR by counting sort on the lower index.
  previous_start_.swap(start), previous_partner_.swap(partner);
  start.assign(N + 1, 0);
  for (int t = 0; t < nthreads; ++t)
    for (std::size_t n = 0; n < found_count_[t]; ++n) ++start[found_[t].i[n] + 1];
  std::partial_sum(start.begin(), start.end(), start.begin());
  partner.resize(start[N]);
  image.resize(start[N]);
  fill_owners();
  fill_.assign(start.begin(), start.end() - 1);
  for (int t = 0; t < nthreads; ++t) {
    const Found& f = found_[t];
    for (std::size_t n = 0; n < found_count_[t]; ++n) {
      const auto k = fill_[f.i[n]]++;
      partner[k] = f.j[n], image[k] = f.image[n];
    }
  }
  if (history_) {   // each entry's entry in the previous list: the old row's partners sorted in scratch, each new entry looked up there
    // The rows keep their order of discovery: the pair loop sums each particle's forces in row order, and rows sorted
    // here would make a run with the collision log part from the same run without it in the last bits.
    previous_entry_.assign(partner.size(), -1);
#pragma omp parallel num_threads(nthreads)
    {
      std::vector<std::pair<std::uint32_t, std::uint32_t>> old;   // (partner, entry) of the row in the previous list
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < N; ++i) {
        if (i + 1 >= previous_start_.size()) continue;
        old.clear();
        for (std::uint32_t o = previous_start_[i]; o < previous_start_[i + 1]; ++o) old.emplace_back(previous_partner_[o], o);
        std::sort(old.begin(), old.end());   // a partner listed twice (two images) maps to its first entry, as before
        for (std::size_t k = start[i]; k < start[i + 1]; ++k) {
          const auto it = std::lower_bound(old.begin(), old.end(), std::pair<std::uint32_t, std::uint32_t>{partner[k], 0});
          if (it != old.end() && it->first == partner[k]) previous_entry_[k] = std::int64_t(it->second);
        }
      }
    }
  }
  reference_ = x;
  strain_since_build_.setOnes();
  list_reach_ = 2 * (N ? sizes.rmax : 0.0) + range_ + skin_;
  ++builds_;
}

template <int D>
bool NeighbourList<D>::stale_after(double largest_move) const {
  return margin_used_up<D>(skin_, strain_since_build_, list_reach_, largest_move);
}

template <int D>
void NeighbourList<D>::follow_cell(const Vec<D>& scale, const Box<D>& box) {
  constexpr int images = D == 3 ? 27 : 9;
  for (int s = 0; s < images; ++s)
    for (int a = 0, r = s; a < D; ++a, r /= 3) shift[s][a] = (r % 3 - 1) * box.length[a];
  reference_lower_ = box.lower;   // the reference positions follow where the moves are measured: no pass over them here
  strain_since_build_ = strain_since_build_.cwiseProduct(scale);
}

template <int D>
void NeighbourList<D>::save(ByteWriter& w) const {
  w.put(range_), w.put(skin_), w.put(builds_);
  w.put_vector(start), w.put_vector(partner), w.put_vector(image), w.put_vector(shift), w.put_vector(reference_);
  w.put(strain_since_build_), w.put(list_reach_), w.put(reference_lower_);
}

template <int D>
void NeighbourList<D>::load(ByteReader& r) {
  range_ = r.get<double>(), skin_ = r.get<double>(), builds_ = r.get<long>();
  r.get_vector(start), r.get_vector(partner), r.get_vector(image), r.get_vector(shift), r.get_vector(reference_);
  strain_since_build_ = r.get<Vec<D>>(), list_reach_ = r.get<double>(), reference_lower_ = r.get<Vec<D>>();
  // Its indices address arrays at the next step: a state that does not hold together is refused here.
  const auto refuse = [](const char* what) {
    throw std::runtime_error(std::string("saved neighbour list is inconsistent: ") + what);
  };
  const std::size_t rows = start.empty() ? 0 : start.size() - 1;
  if (!start.empty() && (start.front() != 0 || start.back() != partner.size())) refuse("its rows do not cover its pairs");
  if (image.size() != partner.size()) refuse("an image per pair");
  if (!shift.empty() && shift.size() != (D == 3 ? 27u : 9u)) refuse("3^D image shifts");
  if (!reference_.empty() && reference_.size() != rows) refuse("a reference position per row");
  // Every row in order before any is read: a later row's start below an earlier one's let that row run past the pairs.
  for (std::size_t i = 0; i < rows; ++i)
    if (start[i] > start[i + 1]) refuse("rows out of order");
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::uint32_t k = start[i]; k < start[i + 1]; ++k)
      if (partner[k] <= i || partner[k] >= rows || image[k] >= shift.size()) refuse("a pair's partner or image out of range");
  }
  previous_entry_.assign(partner.size(), -1);
  fill_owners();
}

template <int D>
void NeighbourList<D>::fill_owners() {
  owner.resize(partner.size());
  for (std::size_t i = 0; i + 1 < start.size(); ++i) std::fill(owner.begin() + start[i], owner.begin() + start[i + 1], std::uint32_t(i));
}

template class NeighbourList<2>;
template class NeighbourList<3>;

}  // namespace grains
