#include "interactions/gravity_tree.hpp"
#include "interactions/gravity_avx512.hpp"
#include "interactions/gravity_lanes.hpp"
#include "core/morton.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include <immintrin.h>

namespace grains::gravity_tree {

namespace {

constexpr std::size_t W_pad = 16;   // the lists are padded to whole vectors of the widest lane type

using morton::key_bits;
using morton::radix_sort;
using morton::spread_bits;

// A coordinate v in the FP32 frame (relative to `origin`, times il = 1 / len) as float hi + lo: together they
// hold it to about 48 bits, so that differences of such pairs keep FP32 precision however far from the origin.
struct HiLo {
  float hi, lo;
};

inline HiLo hi_lo(double v, double origin, double il) {
  const double u = (v - origin) * il;
  const float hi = float(u);
  return {hi, float(u - double(hi))};
}

// One list's columns, in the order of Tree::Multipole32: positions (FP32: hi and lo parts; FP64: hi alone),
// masses and, for cells, quadrupoles.
template <class S>
struct Columns {
  std::vector<S> x, xl, y, yl, z, zl, m, qxx, qxy, qxz, qyy, qyz, qzz;

  std::array<std::vector<S>*, 13> all() { return {&x, &xl, &y, &yl, &z, &zl, &m, &qxx, &qxy, &qxz, &qyy, &qyz, &qzz}; }
  // Padded with zeros to whole vectors (the kernels mask the padding); returns the entries before it.
  std::size_t pad() {
    const std::size_t n = m.size();
    for (auto* v : all())
      if (!v->empty()) v->resize((n + W_pad - 1) / W_pad * W_pad, S(0));
    return n;
  }
  void clear() {
    for (auto* v : all()) v->clear();
  }
};

// What one group needs: the particles to sum one by one (the group's own first, so member k is entry k)
// and the cells to use whole, in FP64 or as the vector kernels' FP32 copies (Tree::multipoles32_ and the
// particles' copies) when fp32_particles or fp32_cells: positions relative to (gx, gy, gz) in units of len,
// each split into float hi + lo; masses in units of `mass`, quadrupoles in units of mass len^2.
struct Lists {
  Columns<double> particles64, cells64;
  Columns<float> particles32, cells32;
  std::size_t particles = 0, cells = 0;
  bool fp32_particles = false, fp32_cells = false;
  double gx = 0, gy = 0, gz = 0, len = 1, mass = 1;

  void clear() { particles64.clear(), particles32.clear(); }
  void pad_particles() { particles = fp32_particles ? particles32.pad() : particles64.pad(); }
  // The cells `ids` from their FP64 or FP32 records.
  void fill_cells64(const std::vector<std::array<double, 10>>& records, const std::vector<int>& ids) {
    Columns<double>& c = cells64;
    for (auto* v : {&c.x, &c.y, &c.z, &c.m, &c.qxx, &c.qxy, &c.qxz, &c.qyy, &c.qyz, &c.qzz}) v->resize(ids.size());
    for (std::size_t k = 0; k < ids.size(); ++k) {
      const auto& r = records[ids[k]];
      c.x[k] = r[0], c.y[k] = r[1], c.z[k] = r[2], c.m[k] = r[3];
      c.qxx[k] = r[4], c.qxy[k] = r[5], c.qxz[k] = r[6], c.qyy[k] = r[7], c.qyz[k] = r[8], c.qzz[k] = r[9];
    }
    cells = c.pad();
  }
  void fill_cells32(const std::vector<std::array<float, 13>>& records, const std::vector<int>& ids) {
    const auto columns = cells32.all();
    for (auto* v : columns) v->resize(ids.size());
    for (std::size_t k = 0; k < ids.size(); ++k)
      for (std::size_t f = 0; f < columns.size(); ++f) (*columns[f])[k] = records[ids[k]][f];
    cells = cells32.pad();
  }
};

// Sums of one particle: acceleration and potential (both without G).
struct Sums {
  double x = 0, y = 0, z = 0, phi = 0;
};

// ---------------------------------------------------------------------------------------------
// Portable kernels.
// ---------------------------------------------------------------------------------------------

// Particle `self` of the list (at x, y, z) against every other particle of the list.
Sums particle_sums_portable(const Lists& L, std::size_t self, double eps2) {
  const Columns<double>& p = L.particles64;
  const double xi = p.x[self], yi = p.y[self], zi = p.z[self];
  Sums s;
  for (std::size_t j = 0; j < L.particles; ++j) {
    if (j == self) continue;
    const double dx = p.x[j] - xi, dy = p.y[j] - yi, dz = p.z[j] - zi;
    const double r2 = dx * dx + dy * dy + dz * dz + eps2;
    const double w = p.m[j] / (r2 * std::sqrt(r2));
    s.x += w * dx, s.y += w * dy, s.z += w * dz, s.phi -= w * r2;
  }
  return s;
}

// Monopole + quadrupole of the softened kernel: with r = com - x, h = sqrt(|r|^2 + eps^2), Q = 3 sum m d d^T (d from
// the centre of mass; not traceless) and S = tr Q / 3 = sum m |d|^2,
// phi = -(M / h + r.Q.r / (2 h^5) - S / (2 h^3)), a = (M / h^3 + 5/2 (r.Q.r) / h^7 - 3/2 S / h^5) r - Q r / h^5.
// The S terms are the softening's part of the second order (the kernel's Hessian is -I / h^3 + 3 r r^T / h^5, not
// traceless where eps > 0): without them (a traceless Q) the force errs by 1e-5 where 2e-7 is due (cells seen at 150
// from a softening of 600), with a median of 1.2e-3 in a ball at softening 10 (2.4e-4 expected). With eps = 0 they
// cancel the trace exactly.
void cell_sums_portable(const Lists& L, double xi, double yi, double zi, double eps2, Sums& s) {
  const Columns<double>& c = L.cells64;
  for (std::size_t j = 0; j < L.cells; ++j) {
    const double dx = c.x[j] - xi, dy = c.y[j] - yi, dz = c.z[j] - zi;
    const double inv = 1.0 / std::sqrt(dx * dx + dy * dy + dz * dz + eps2);
    const double inv2 = inv * inv, inv3 = inv * inv2, inv5 = inv3 * inv2;
    const double qx = c.qxx[j] * dx + c.qxy[j] * dy + c.qxz[j] * dz;
    const double qy = c.qxy[j] * dx + c.qyy[j] * dy + c.qyz[j] * dz;
    const double qz = c.qxz[j] * dx + c.qyz[j] * dy + c.qzz[j] * dz;
    const double rQr = dx * qx + dy * qy + dz * qz, trace = c.qxx[j] + c.qyy[j] + c.qzz[j];   // trace = 3 S
    const double a = c.m[j] * inv3 + 2.5 * rQr * inv5 * inv2 - 0.5 * trace * inv5;
    s.x += a * dx - inv5 * qx, s.y += a * dy - inv5 * qy, s.z += a * dz - inv5 * qz;
    s.phi -= c.m[j] * inv + 0.5 * rQr * inv5 - trace * inv3 / 6;
  }
}

Sums sums_portable(const Lists& L, std::size_t self, double eps2) {
  Sums s = particle_sums_portable(L, self, eps2);
  cell_sums_portable(L, L.particles64.x[self], L.particles64.y[self], L.particles64.z[self], eps2, s);
  return s;
}

// ---------------------------------------------------------------------------------------------
// Vector kernels (gravity_tree_sums.inc), once per instruction set.
// FP32 is safe where they use it: a cell term is an expansion whose truncation error is ~1e-4 relative at
// theta 0.5 (~1e-5 at theta 0.2; the tree's median force error is ~2e-4 at 0.5), and a particle's near field
// is one part of a sum carrying that error; FP32 rounding is ~1e-7 relative. Large coordinates lose nothing:
// positions are taken relative to the tree's origin in FP64 and split into float hi + lo, so
// (hi_j - hi_i) + (lo_j - lo_i) is the FP64 displacement to about FP32 precision however far from the
// origin. Lengths and masses are in power-of-two units (exact scaling) fitted to the tree, and the walk
// keeps FP64 where h could leave the range in which h^-7 and the like stay normal floats (Tree::evaluate).
// Each particle's sums stay in FP32 lanes to the end of its lists (about a hundred terms a lane), then are
// widened, scaled back and summed in FP64 in a fixed order: deterministic. Measured against the FP64
// kernels: within 1e-6 of each particle's acceleration (tests/engine/test_gravity.cpp, bound 4e-6).
// ---------------------------------------------------------------------------------------------

namespace avx2 {
using Exact = lanes::Avx2F64;
using Fast = lanes::Avx2F32;
#define GRAINS_GRAVITY_KERNEL GRAINS_AVX2
#include "interactions/gravity_tree_sums.inc"
#undef GRAINS_GRAVITY_KERNEL
}  // namespace avx2

// GCC 12's avx512fintrin.h fills "undefined" vectors by self-initialisation, which -Wuninitialized flags.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace avx512 {
using Exact = lanes::Avx512F64;
using Fast = lanes::Avx512F32;
#define GRAINS_GRAVITY_KERNEL GRAINS_AVX512
#include "interactions/gravity_tree_sums.inc"
#undef GRAINS_GRAVITY_KERNEL
}  // namespace avx512

// ---------------------------------------------------------------------------------------------
// Walk of one group (cell `group`, box lo .. hi): from the root down, the children of every opened cell are
// tested in turn; those whose centre of mass lies beyond their opening distance from the box are used whole
// (their ids appended to `used`), leaves among the rest give their particles (`add(begin, end)`), and the
// other cells are opened in their turn, last pushed first. The group's own cell is skipped (its particles
// come first in the lists), and a cell holding the group is always opened: mathematically it never lies
// beyond its b_max from the box, but at equality (the group at the far corner of the cell's box) rounding
// could pass it. All three walks give the same lists in the same order (gravity_tree.cpp is compiled without
// multiply-add contraction, so d2 rounds alike); they return the least squared distance of a used cell to
// the box.
// ---------------------------------------------------------------------------------------------

template <class Nodes, class AddParticles>
double walk_portable(const Nodes& N, int group, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                     std::vector<int>& stack, std::vector<int>& used, AddParticles&& add) {
  double near2 = std::numeric_limits<double>::infinity();
  if (group == 0) return near2;   // the whole tree is the group
  const int group_begin = N.begin[group], group_end = N.end[group];
  stack.assign(1, 0);
  while (!stack.empty()) {
    const int id = stack.back();
    stack.pop_back();
    for (int k = N.first_child[id], last = k + N.children[id]; k < last; ++k) {
      if (k == group) continue;
      // From the centre of mass to the group's box.
      const double dx = std::max({lo[0] - N.cx[k], N.cx[k] - hi[0], 0.0});
      const double dy = std::max({lo[1] - N.cy[k], N.cy[k] - hi[1], 0.0});
      const double dz = std::max({lo[2] - N.cz[k], N.cz[k] - hi[2], 0.0});
      const double d2 = dx * dx + dy * dy + dz * dz;
      const bool holds_group = N.begin[k] <= group_begin && group_end <= N.end[k];
      if (d2 > N.accept2[k] && !holds_group) {
        used.push_back(k), near2 = std::min(near2, d2);
      } else if (N.children[k] == 0) {
        add(N.begin[k], N.end[k]);
      } else {
        stack.push_back(k);
      }
    }
  }
  return near2;
}

// The same walk with the (at most eight) children of a cell tested in two AVX2 vectors of four; the ids taken
// from the masks bit by bit, in order. (Zero is max's first operand, so that a NaN distance stays NaN, as in
// std::max, and the cell is opened alike.)
template <class Nodes, class AddParticles>
GRAINS_AVX2 double walk_avx2(const Nodes& N, int group, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                             std::vector<int>& stack, std::vector<int>& used, AddParticles&& add) {
  double near2 = std::numeric_limits<double>::infinity();
  if (group == 0) return near2;
  const __m256d lx = _mm256_set1_pd(lo[0]), ly = _mm256_set1_pd(lo[1]), lz = _mm256_set1_pd(lo[2]);
  const __m256d hx = _mm256_set1_pd(hi[0]), hy = _mm256_set1_pd(hi[1]), hz = _mm256_set1_pd(hi[2]);
  const __m256d zero = _mm256_setzero_pd();
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i group_begin = _mm256_set1_epi32(N.begin[group]), group_end = _mm256_set1_epi32(N.end[group]);
  // The squared distances of children j0 .. j0 + 3 (lanes past `count` read nothing) and the lanes whose
  // distance exceeds their opening distance, as bits.
  auto test4 = [&](int first, int j0, int count, __m256d& d2) GRAINS_AVX2 {
    const __m256i in = _mm256_cmpgt_epi64(_mm256_set1_epi64x(count - j0), _mm256_setr_epi64x(0, 1, 2, 3));
    const __m256d cx = _mm256_maskload_pd(&N.cx[first + j0], in), cy = _mm256_maskload_pd(&N.cy[first + j0], in);
    const __m256d cz = _mm256_maskload_pd(&N.cz[first + j0], in), accept2 = _mm256_maskload_pd(&N.accept2[first + j0], in);
    const __m256d dx = _mm256_max_pd(zero, _mm256_max_pd(_mm256_sub_pd(lx, cx), _mm256_sub_pd(cx, hx)));
    const __m256d dy = _mm256_max_pd(zero, _mm256_max_pd(_mm256_sub_pd(ly, cy), _mm256_sub_pd(cy, hy)));
    const __m256d dz = _mm256_max_pd(zero, _mm256_max_pd(_mm256_sub_pd(lz, cz), _mm256_sub_pd(cz, hz)));
    d2 = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz));
    return unsigned(_mm256_movemask_pd(_mm256_and_pd(_mm256_cmp_pd(d2, accept2, _CMP_GT_OQ), _mm256_castsi256_pd(in))));
  };
  stack.assign(1, 0);
  while (!stack.empty()) {
    const int id = stack.back();
    stack.pop_back();
    const int first = N.first_child[id], count = N.children[id];
    const __m256i in = _mm256_cmpgt_epi32(_mm256_set1_epi32(count), lane);
    const unsigned kids = (1u << count) - 1;
    const unsigned self = group >= first && group < first + count ? 1u << (group - first) : 0u;
    const __m256i b = _mm256_maskload_epi32(&N.begin[first], in), e = _mm256_maskload_epi32(&N.end[first], in);
    const __m256i holds = _mm256_andnot_si256(_mm256_or_si256(_mm256_cmpgt_epi32(b, group_begin), _mm256_cmpgt_epi32(group_end, e)), in);
    const unsigned holds_group = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(holds)));
    __m256d d2lo, d2hi = zero;
    unsigned beyond = test4(first, 0, count, d2lo);
    if (count > 4) beyond |= test4(first, 4, count, d2hi) << 4;
    const unsigned use = beyond & kids & ~holds_group;
    if (use) {
      alignas(32) double d2[8];
      _mm256_store_pd(d2, d2lo), _mm256_store_pd(d2 + 4, d2hi);
      for (unsigned bits = use; bits; bits &= bits - 1) {
        const int j = __builtin_ctz(bits);
        used.push_back(first + j), near2 = std::min(near2, d2[j]);
      }
    }
    const unsigned open = kids & ~self & ~use;
    if (open) {
      const __m256i children = _mm256_maskload_epi32(&N.children[first], in);
      const unsigned leaf = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(children, _mm256_setzero_si256()))));
      for (unsigned bits = open & leaf; bits; bits &= bits - 1) {
        const int k = first + __builtin_ctz(bits);
        add(N.begin[k], N.end[k]);
      }
      for (unsigned bits = open & ~leaf; bits; bits &= bits - 1) stack.push_back(first + __builtin_ctz(bits));
    }
  }
  return near2;
}

// The same walk with the (at most eight) children of a cell tested in one vector: their used and opened ids
// compressed in a register, in order, and stored whole (into 16 slots of slack: a compressing store to
// memory is slow on some processors). The distances are formed as in walk_portable (no multiply-add), so
// every decision is the same.
template <class Nodes, class AddParticles>
GRAINS_AVX512 double walk_avx512(const Nodes& N, int group, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
                                 std::vector<int>& stack, std::vector<int>& used, AddParticles&& add) {
  double near2 = std::numeric_limits<double>::infinity();
  if (group == 0) return near2;
  const __m512d lx = _mm512_set1_pd(lo[0]), ly = _mm512_set1_pd(lo[1]), lz = _mm512_set1_pd(lo[2]);
  const __m512d hx = _mm512_set1_pd(hi[0]), hy = _mm512_set1_pd(hi[1]), hz = _mm512_set1_pd(hi[2]);
  const __m512d zero = _mm512_setzero_pd();
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512i group_begin = _mm512_set1_epi32(N.begin[group]), group_end = _mm512_set1_epi32(N.end[group]);
  std::size_t top = 0, n_used = used.size();
  stack.resize(64), stack[top++] = 0;
  while (top > 0) {
    const int id = stack[--top];
    const int first = N.first_child[id], count = N.children[id];
    const __mmask8 kids = __mmask8((1u << count) - 1);
    const __m512d cx = _mm512_maskz_loadu_pd(kids, &N.cx[first]), cy = _mm512_maskz_loadu_pd(kids, &N.cy[first]);
    const __m512d cz = _mm512_maskz_loadu_pd(kids, &N.cz[first]), accept2 = _mm512_maskz_loadu_pd(kids, &N.accept2[first]);
    const __m512d dx = _mm512_max_pd(zero, _mm512_max_pd(_mm512_sub_pd(lx, cx), _mm512_sub_pd(cx, hx)));
    const __m512d dy = _mm512_max_pd(zero, _mm512_max_pd(_mm512_sub_pd(ly, cy), _mm512_sub_pd(cy, hy)));
    const __m512d dz = _mm512_max_pd(zero, _mm512_max_pd(_mm512_sub_pd(lz, cz), _mm512_sub_pd(cz, hz)));
    const __m512d d2 = _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(dx, dx), _mm512_mul_pd(dy, dy)), _mm512_mul_pd(dz, dz));
    const unsigned self = group >= first && group < first + count ? 1u << (group - first) : 0u;
    const __mmask16 k16 = __mmask16(kids);
    const unsigned holds_group = _mm512_mask_cmple_epi32_mask(k16, _mm512_maskz_loadu_epi32(k16, &N.begin[first]), group_begin) &
                                 _mm512_mask_cmpge_epi32_mask(k16, _mm512_maskz_loadu_epi32(k16, &N.end[first]), group_end);
    const __mmask8 use = _mm512_mask_cmp_pd_mask(__mmask8(kids & ~holds_group), d2, accept2, _CMP_GT_OQ);
    const unsigned open = kids & ~self & ~unsigned(use);
    const __m512i ids = _mm512_add_epi32(_mm512_set1_epi32(first), lane);
    if (use) {
      used.resize(n_used + 16);
      _mm512_storeu_si512(&used[n_used], _mm512_maskz_compress_epi32(use, ids));
      n_used += std::size_t(__builtin_popcount(use));
      used.resize(n_used);
      near2 = std::min(near2, _mm512_mask_reduce_min_pd(use, d2));
    }
    if (open) {
      const __mmask16 leaves = __mmask16(open) & _mm512_cmpeq_epi32_mask(_mm512_maskz_loadu_epi32(k16, &N.children[first]),
                                                                        _mm512_setzero_si512());
      for (unsigned bits = leaves; bits; bits &= bits - 1) {
        const int k = first + __builtin_ctz(bits);
        add(N.begin[k], N.end[k]);
      }
      const __mmask16 inner = __mmask16(open & ~unsigned(leaves));
      if (top + 16 > stack.size()) stack.resize(2 * stack.size() + 16);
      _mm512_storeu_si512(&stack[top], _mm512_maskz_compress_epi32(inner, ids));
      top += std::size_t(__builtin_popcount(inner));
    }
  }
  return near2;
}
#pragma GCC diagnostic pop

// The walk of the kernel set `isa`.
template <class Nodes, class AddParticles>
double walk_of(const Nodes& N, Isa isa, int group, const std::array<double, 3>& lo, const std::array<double, 3>& hi,
               std::vector<int>& stack, std::vector<int>& used, AddParticles&& add) {
  if (isa == Isa::avx512) return walk_avx512(N, group, lo, hi, stack, used, add);
  if (isa == Isa::avx2) return walk_avx2(N, group, lo, hi, stack, used, add);
  return walk_portable(N, group, lo, hi, stack, used, add);
}

}  // namespace

Tree::Walk Tree::walk(Isa isa, std::size_t g) const {
  Walk w;
  std::vector<int> stack;
  const Cell& c = cells_[groups_.at(g)];
  w.near2 = walk_of(nodes_, isa, groups_[g], c.lo, c.hi, stack, w.cells, [&w](int from, int to) { w.ranges.emplace_back(from, to); });
  return w;
}

// ---------------------------------------------------------------------------------------------
// Build.
// ---------------------------------------------------------------------------------------------

template <int D>
Tree::Tree(const Particles<D>& P, double theta, int threads, int leaf_size, int group_size)
    : theta_(theta), leaf_size_(std::max(1, leaf_size)), group_size_(std::max(1, group_size)) {
  const std::size_t n = P.size();
  if (n == 0) return;
  // The root cube: the bounding box's centre and its longest half edge, widened a little.
  Vec<D> lo = P.position[0], hi = P.position[0];
  double total_mass = 0;
  for (std::size_t i = 0; i < n; ++i) lo = lo.cwiseMin(P.position[i]), hi = hi.cwiseMax(P.position[i]), total_mass += P.mass[i];
  const double half = 0.5 * (hi - lo).maxCoeff() * (1 + 1e-12) + 1e-300;
  const Vec<D> centre = 0.5 * (lo + hi);
  // The FP32 copies' frame: the root cube's centre, powers of two near its edge and the total mass.
  for (int a = 0; a < D; ++a) origin_[a] = centre[a];
  len_ = std::ldexp(1.0, std::ilogb(2 * half));
  mass_unit_ = total_mass > 0 ? std::ldexp(1.0, std::ilogb(total_mass)) : 1.0;
  const double il = 1 / len_, im = 1 / mass_unit_, iq = im * il * il;   // powers of two: exact
  auto split = [&](double v, int a, float& high, float& low) {
    const HiLo h = hi_lo(v, origin_[a], il);
    high = h.hi, low = h.lo;
  };
  auto normal_fp32 = [im](double m) { return m == 0 || m * im >= 1e-20; };
  // Morton keys: each coordinate quantised to key_bits<D> bits, the bits interleaved (axis a at bit a of
  // every D-bit digit, the top digit naming the root's child).
  constexpr int bits = key_bits<D>;
  const double scale = std::ldexp(1.0, bits) / (2 * half);
  const double top = std::ldexp(1.0, bits) - 1;
  std::vector<unsigned long long> keys(n);
  order_.resize(n);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    unsigned long long key = 0;
    for (int a = 0; a < D; ++a) {
      // Clamped in floating point (q >= 0 bar round-off): the conversion then truncates like floor.
      const double q = std::clamp((P.position[i][a] - (centre[a] - half)) * scale, 0.0, top);
      key |= spread_bits<D>(static_cast<unsigned long long>(q)) << a;
    }
    keys[i] = key, order_[i] = int(i);
  }
  radix_sort(keys, order_);
  // The FP32 copies only where the kernels may read them (Tree::evaluate): the vector kernels (AVX2 at least),
  // from fp32_min_theta on.
  const bool fp32 = theta_ >= fp32_min_theta && gravity_direct::supported(Isa::avx2);
  for (auto* v : {&x_, &y_, &z_, &m_}) v->assign(n, 0.0);
  for (auto* v : {&xh_, &xl_, &yh_, &yl_, &zh_, &zl_, &m32_}) v->assign(fp32 ? n : 0, 0.0f);
  bool masses_ok = fp32;
#pragma omp parallel for num_threads(threads) schedule(static) reduction(&& : masses_ok)
  for (std::size_t k = 0; k < n; ++k) {
    x_[k] = P.position[order_[k]][0], y_[k] = P.position[order_[k]][1], m_[k] = P.mass[order_[k]];
    if constexpr (D == 3) z_[k] = P.position[order_[k]][2];
    if (!fp32) continue;
    split(x_[k], 0, xh_[k], xl_[k]), split(y_[k], 1, yh_[k], yl_[k]), split(z_[k], 2, zh_[k], zl_[k]);
    m32_[k] = float(m_[k] * im), masses_ok = masses_ok && normal_fp32(m_[k]);
  }
  cells_.reserve(4 * n / std::size_t(leaf_size_) + 16);
  cells_.emplace_back();
  build<D>(0, 0, int(n), 0, false, keys);
  quad_.assign(cells_.size(), Quadrupole{});
  for (int id = int(cells_.size()) - 1; id >= 0; --id) moments(id);   // children come after their parent
  const std::size_t cells = cells_.size();
  for (auto* v : {&nodes_.cx, &nodes_.cy, &nodes_.cz, &nodes_.accept2}) v->resize(cells);
  for (auto* v : {&nodes_.first_child, &nodes_.children, &nodes_.begin, &nodes_.end}) v->resize(cells);
  multipoles_.resize(cells);
  multipoles32_.resize(fp32 ? cells : 0);
#pragma omp parallel for num_threads(threads) schedule(static) reduction(&& : masses_ok)
  for (std::size_t id = 0; id < cells; ++id) {
    const Cell& c = cells_[id];
    const Quadrupole& Q = quad_[id];
    nodes_.cx[id] = c.com[0], nodes_.cy[id] = c.com[1], nodes_.cz[id] = c.com[2], nodes_.accept2[id] = c.accept2;
    nodes_.first_child[id] = c.first_child, nodes_.children[id] = c.children, nodes_.begin[id] = c.begin, nodes_.end[id] = c.end;
    multipoles_[id] = {c.com[0], c.com[1], c.com[2], c.mass, Q[0], Q[1], Q[2], Q[3], Q[4], Q[5]};
    if (!fp32) continue;
    Multipole32& f = multipoles32_[id];
    split(c.com[0], 0, f[0], f[1]), split(c.com[1], 1, f[2], f[3]), split(c.com[2], 2, f[4], f[5]);
    f[6] = float(c.mass * im), masses_ok = masses_ok && normal_fp32(c.mass);
    for (int e = 0; e < 6; ++e) f[7 + e] = float(Q[e] * iq);
  }
  fp32_masses_ = masses_ok;   // false without the copies: then evaluate keeps FP64
}

// Splits cell `id` over the particles [begin, end) at Morton digit `level`; the first cell on the way down
// that is small enough, or a leaf, becomes a group.
template <int D>
void Tree::build(int id, int begin, int end, int level, bool in_group, const std::vector<unsigned long long>& keys) {
  cells_[id].begin = begin, cells_[id].end = end;
  const bool leaf = end - begin <= leaf_size_ || level == key_bits<D>;
  if (!in_group && (end - begin <= group_size_ || leaf)) groups_.push_back(id), in_group = true;
  if (leaf) return;
  // The keys are sorted: each child's particles are one run of equal digits.
  const int shift = D * (key_bits<D> - 1 - level);
  auto digit = [&](int k) { return int((keys[k] >> shift) & ((1ULL << D) - 1)); };
  std::array<int, (1 << D) + 1> run_start{};
  int runs = 0;
  for (int k = begin; k < end; ++k)
    if (k == begin || digit(k) != digit(k - 1)) run_start[runs++] = k;
  run_start[runs] = end;
  const int first = int(cells_.size());
  cells_.resize(cells_.size() + runs);
  cells_[id].first_child = first, cells_[id].children = runs;
  for (int r = 0; r < runs; ++r) build<D>(first + r, run_start[r], run_start[r + 1], level + 1, in_group, keys);
}

// Mass, centre of mass, quadrupole and bounding box of cell `id`, from its particles (leaf) or its children.
void Tree::moments(int id) {
  Cell& c = cells_[id];
  Quadrupole& Q = quad_[id];
  // Adds 3 m d d^T to Q (see cell_sums_portable).
  auto add = [&Q](double m, double dx, double dy, double dz) {
    Q[0] += m * 3 * dx * dx, Q[1] += m * 3 * dx * dy, Q[2] += m * 3 * dx * dz;
    Q[3] += m * 3 * dy * dy, Q[4] += m * 3 * dy * dz, Q[5] += m * 3 * dz * dz;
  };
  double mass = 0, mx = 0, my = 0, mz = 0;
  if (c.children == 0) {
    c.lo = {x_[c.begin], y_[c.begin], z_[c.begin]}, c.hi = c.lo;
    for (int k = c.begin; k < c.end; ++k) {
      mass += m_[k], mx += m_[k] * x_[k], my += m_[k] * y_[k], mz += m_[k] * z_[k];
      const std::array<double, 3> x{x_[k], y_[k], z_[k]};
      for (int a = 0; a < 3; ++a) c.lo[a] = std::min(c.lo[a], x[a]), c.hi[a] = std::max(c.hi[a], x[a]);
    }
  } else {
    c.lo = cells_[c.first_child].lo, c.hi = cells_[c.first_child].hi;
    for (int k = c.first_child; k < c.first_child + c.children; ++k) {
      const Cell& s = cells_[k];
      mass += s.mass, mx += s.mass * s.com[0], my += s.mass * s.com[1], mz += s.mass * s.com[2];
      for (int a = 0; a < 3; ++a) c.lo[a] = std::min(c.lo[a], s.lo[a]), c.hi[a] = std::max(c.hi[a], s.hi[a]);
    }
  }
  c.mass = mass;
  c.com = mass > 0 ? std::array<double, 3>{mx / mass, my / mass, mz / mass}
                   : std::array<double, 3>{0.5 * (c.lo[0] + c.hi[0]), 0.5 * (c.lo[1] + c.hi[1]), 0.5 * (c.lo[2] + c.hi[2])};
  if (c.children == 0) {
    for (int k = c.begin; k < c.end; ++k) add(m_[k], x_[k] - c.com[0], y_[k] - c.com[1], z_[k] - c.com[2]);
  } else {
    for (int k = c.first_child; k < c.first_child + c.children; ++k) {
      const Cell& s = cells_[k];
      for (int e = 0; e < 6; ++e) Q[e] += quad_[k][e];
      add(s.mass, s.com[0] - c.com[0], s.com[1] - c.com[1], s.com[2] - c.com[2]);
    }
  }
  // Opening distance: s / theta with s the longest edge of the particles' box (tight: a cell holding a
  // small clump counts as small), but never less than b_max, the distance from the centre of mass to the
  // box's farthest corner, so that the target lies outside every particle of the cell (the expansion's
  // convergence radius) even when the centre of mass sits near one edge. For cells along the box's diagonal
  // b_max is 0.87 s: from theta = 1.15 on b_max decides, and at theta = 1 a cell beside the group is used whole with
  // b / d up to 0.87 (a line of grains along the diagonal: errors of 0.29 of the terms' scale at theta 1, 1.6e-3
  // at 0.9). The schema says so.
  double edge = 0, b2 = 0;
  for (int a = 0; a < 3; ++a) {
    edge = std::max(edge, c.hi[a] - c.lo[a]);
    const double b = std::max(c.com[a] - c.lo[a], c.hi[a] - c.com[a]);
    b2 += b * b;
  }
  const double lim = std::max(edge / theta_, std::sqrt(b2));
  // A lone particle is summed exactly, never as a cell.
  c.accept2 = theta_ > 0 && c.end - c.begin > 1 ? lim * lim : std::numeric_limits<double>::infinity();
}

template Tree::Tree(const Particles<2>&, double, int, int, int);
template Tree::Tree(const Particles<3>&, double, int, int, int);

// ---------------------------------------------------------------------------------------------
// Walk.
// ---------------------------------------------------------------------------------------------

Tree::Counts Tree::evaluate(Isa isa, double eps2, int threads, std::vector<double>& ax, std::vector<double>& ay,
                            std::vector<double>& az, std::vector<double>* phi) const {
  const std::size_t n = order_.size();
  for (auto* v : {&ax, &ay, &az}) v->assign(n, 0.0);
  if (phi) phi->assign(n, 0.0);
  auto* sums = isa == Isa::portable ? sums_portable
              : isa == Isa::avx2    ? (phi ? avx2::sums<true> : avx2::sums<false>)
                                    : (phi ? avx512::sums<true> : avx512::sums<false>);
  // FP32 sums where h / len lies in [1e-5, 1e5] for every pair summed (all lie within the
  // root box, < 4 len apart) and every mass is normal in FP32: then h^-5, h^-7 M and the like stay normal
  // floats. Particles: h >= eps, so the softening decides for the whole walk. Cells: h^2 >= near2 + eps2,
  // decided group by group.
  const double scaled_eps2 = eps2 / (len_ * len_);
  const bool fp32 = isa != Isa::portable && theta_ >= fp32_min_theta && fp32_masses_ && scaled_eps2 <= 1e10;
  const bool fp32_particles = fp32 && scaled_eps2 >= 1e-10;
  std::size_t pairs = 0, cell_terms = 0;
#pragma omp parallel num_threads(threads) reduction(+ : pairs, cell_terms)
  {
    Lists L;
    L.fp32_particles = fp32_particles;
    L.gx = origin_[0], L.gy = origin_[1], L.gz = origin_[2], L.len = len_, L.mass = mass_unit_;
    std::vector<int> stack, used;
#pragma omp for schedule(dynamic, 4)
    for (std::size_t g = 0; g < groups_.size(); ++g) {
      const Cell& group = cells_[groups_[g]];
      const int b = group.begin, e = group.end;
      const std::array<double, 3>&lo = group.lo, &hi = group.hi;   // the group's bounding box
      L.clear();
      // Pointers by data() + index: &x_[to] with to == size() is out of range for operator[].
      auto add_particles = [&](int from, int to) {
        auto add = [from, to](auto& list, const auto& v) {
          list.insert(list.end(), v.data() + from, v.data() + to);
        };
        if (L.fp32_particles) {
          Columns<float>& p = L.particles32;
          add(p.x, xh_), add(p.xl, xl_), add(p.y, yh_), add(p.yl, yl_), add(p.z, zh_), add(p.zl, zl_), add(p.m, m32_);
        } else {
          Columns<double>& p = L.particles64;
          add(p.x, x_), add(p.y, y_), add(p.z, z_), add(p.m, m_);
        }
      };
      add_particles(b, e);
      // Cells used whole are noted during the walk and copied into the lists after it.
      used.clear();
      // The least squared distance of a used cell to the group's box.
      const double near2 = walk_of(nodes_, isa, groups_[g], lo, hi, stack, used, add_particles);
      L.pad_particles();
      const std::size_t u = used.size();
      L.fp32_cells = fp32_particles || (fp32 && u > 0 && (near2 + eps2) / (len_ * len_) >= 1e-10);
      if (L.fp32_cells)
        L.fill_cells32(multipoles32_, used);
      else
        L.fill_cells64(multipoles_, used);
      pairs += (L.particles - 1) * std::size_t(e - b), cell_terms += L.cells * std::size_t(e - b);
      for (int k = b; k < e; ++k) {
        const Sums s = sums(L, std::size_t(k - b), eps2);
        const int i = order_[k];
        ax[i] = s.x, ay[i] = s.y, az[i] = s.z;
        if (phi) (*phi)[i] = s.phi;
      }
    }
  }
  return Counts{pairs, cell_terms};
}

}  // namespace grains::gravity_tree
