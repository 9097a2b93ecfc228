#include "interactions/gravity_direct.hpp"
#include "interactions/gravity_avx512.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include <immintrin.h>

namespace grains::gravity_direct {

bool supported(Isa isa) {
  switch (isa) {
    case Isa::avx512: return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    default: return true;
  }
}

const char* isa_name(Isa isa) { return isa == Isa::avx512 ? "avx512" : isa == Isa::avx2 ? "avx2" : "portable"; }

Isa fastest_isa() {
  static const Isa isa = [] {
    if (const char* want = std::getenv("GRAINS_GRAVITY_ISA"))
      for (Isa i : {Isa::portable, Isa::avx2, Isa::avx512})
        if (std::strcmp(want, isa_name(i)) == 0 && supported(i)) return i;
    return supported(Isa::avx512) ? Isa::avx512 : supported(Isa::avx2) ? Isa::avx2 : Isa::portable;
  }();
  return isa;
}

namespace {

constexpr std::size_t W = 4;   // doubles per AVX2 vector

// Where a tile adds acceleration terms: particle k's into x[k - first], y[k - first], z[k - first].
struct Sums {
  double *x, *y, *z;
  std::size_t first;
};

// ---------------------------------------------------------------------------------------------
// Portable kernels.
// ---------------------------------------------------------------------------------------------

// Pairs (i, j), i in block I, j in block J (j > i when I == J): a_i += m_j g_ij into `si`, a_j -= m_i g_ij
// into `sj`.
void tile_portable(const Columns& c, double eps2, std::size_t I, std::size_t J, Sums si, Sums sj) {
  const std::size_t B = c.block;
  const std::size_t i1 = std::min(I * B + B, c.n), j1 = std::min(J * B + B, c.n);
  for (std::size_t i = I * B; i < i1; ++i) {
    const double xi = c.x[i], yi = c.y[i], zi = c.z[i], mi = c.m[i];
    double sx = 0, sy = 0, sz = 0;
    for (std::size_t j = I == J ? i + 1 : J * B; j < j1; ++j) {
      const double dx = c.x[j] - xi, dy = c.y[j] - yi, dz = c.z[j] - zi;
      const double r2 = dx * dx + dy * dy + dz * dz + eps2;
      const double t = 1.0 / (r2 * std::sqrt(r2));
      const double wi = c.m[j] * t, wj = mi * t;
      sx += wi * dx, sy += wi * dy, sz += wi * dz;
      sj.x[j - sj.first] -= wj * dx, sj.y[j - sj.first] -= wj * dy, sj.z[j - sj.first] -= wj * dz;
    }
    si.x[i - si.first] += sx, si.y[i - si.first] += sy, si.z[i - si.first] += sz;
  }
}

// sum_{j > i} m_j / sqrt(d^2 + eps^2).
double potential_row_portable(const Columns& c, double eps2, std::size_t i) {
  const double xi = c.x[i], yi = c.y[i], zi = c.z[i];
  double s = 0;
  for (std::size_t j = i + 1; j < c.n; ++j) {
    const double dx = c.x[j] - xi, dy = c.y[j] - yi, dz = c.z[j] - zi;
    s += c.m[j] / std::sqrt(dx * dx + dy * dy + dz * dz + eps2);
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// AVX2 + FMA kernels: the same sums, four j at a time (lane k takes j = 4q + k; lanes are added in a fixed
// order at the end of a row). The square root and division run on the divider while the FMA units do the
// rest; on the machine this was tuned on (AMD Zen 3) that beat an FP32 rsqrt estimate refined in FP64.
// ---------------------------------------------------------------------------------------------
#define GRAINS_AVX2 __attribute__((target("avx2,fma")))

// Lanes j0 .. j0 + 3 with first <= j < end, as a mask of all ones or all zeros per lane.
GRAINS_AVX2 inline __m256d lanes_in(std::size_t j0, std::size_t first, std::size_t end) {
  const __m256i j = _mm256_add_epi64(_mm256_set1_epi64x(static_cast<long long>(j0)), _mm256_setr_epi64x(0, 1, 2, 3));
  const __m256i from = _mm256_cmpgt_epi64(j, _mm256_set1_epi64x(static_cast<long long>(first) - 1));
  const __m256i below = _mm256_cmpgt_epi64(_mm256_set1_epi64x(static_cast<long long>(end)), j);
  return _mm256_castsi256_pd(_mm256_and_si256(from, below));
}

// Lane sum in a fixed order.
GRAINS_AVX2 inline double lane_sum(__m256d v) {
  const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));   // (0+2, 1+3)
  return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}

// Particle i, broadcast, and its running sums.
struct Row {
  __m256d x, y, z, m, eps2;
  __m256d sx, sy, sz;
};

// Pairs (i, j0 .. j0 + 3) into both sides; with `masked`, lanes outside `keep` add nothing (their
// 1 / (r2 sqrt(r2)) may be infinite: self, padding).
template <bool masked>
GRAINS_AVX2 inline void add_pairs(const Columns& c, std::size_t j0, __m256d keep, Row& r, Sums sj) {
  const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(&c.x[j0]), r.x);
  const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(&c.y[j0]), r.y);
  const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(&c.z[j0]), r.z);
  __m256d r2 = _mm256_fmadd_pd(dx, dx, r.eps2);
  r2 = _mm256_fmadd_pd(dy, dy, r2);
  r2 = _mm256_fmadd_pd(dz, dz, r2);
  __m256d t = _mm256_div_pd(_mm256_set1_pd(1.0), _mm256_mul_pd(r2, _mm256_sqrt_pd(r2)));
  if constexpr (masked) t = _mm256_and_pd(t, keep);
  const __m256d wi = _mm256_mul_pd(_mm256_loadu_pd(&c.m[j0]), t), wj = _mm256_mul_pd(r.m, t);
  r.sx = _mm256_fmadd_pd(wi, dx, r.sx), r.sy = _mm256_fmadd_pd(wi, dy, r.sy), r.sz = _mm256_fmadd_pd(wi, dz, r.sz);
  double *x = &sj.x[j0 - sj.first], *y = &sj.y[j0 - sj.first], *z = &sj.z[j0 - sj.first];
  _mm256_storeu_pd(x, _mm256_fnmadd_pd(wj, dx, _mm256_loadu_pd(x)));
  _mm256_storeu_pd(y, _mm256_fnmadd_pd(wj, dy, _mm256_loadu_pd(y)));
  _mm256_storeu_pd(z, _mm256_fnmadd_pd(wj, dz, _mm256_loadu_pd(z)));
}

GRAINS_AVX2 void tile_avx2(const Columns& c, double eps2, std::size_t I, std::size_t J, Sums si, Sums sj) {
  const std::size_t B = c.block;
  const std::size_t i1 = std::min(I * B + B, c.n), j1 = std::min(J * B + B, (c.n + W - 1) / W * W);
  for (std::size_t i = I * B; i < i1; ++i) {
    Row r{_mm256_set1_pd(c.x[i]), _mm256_set1_pd(c.y[i]), _mm256_set1_pd(c.z[i]), _mm256_set1_pd(c.m[i]),
          _mm256_set1_pd(eps2), _mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd()};
    const std::size_t first = I == J ? i + 1 : J * B;   // the first j of the row
    for (std::size_t j0 = first / W * W; j0 < j1; j0 += W) {
      if (j0 < first || j0 + W > c.n)
        add_pairs<true>(c, j0, lanes_in(j0, first, c.n), r, sj);
      else
        add_pairs<false>(c, j0, _mm256_setzero_pd(), r, sj);
    }
    si.x[i - si.first] += lane_sum(r.sx), si.y[i - si.first] += lane_sum(r.sy), si.z[i - si.first] += lane_sum(r.sz);
  }
}

GRAINS_AVX2 double potential_row_avx2(const Columns& c, double eps2, std::size_t i) {
  const __m256d xi = _mm256_set1_pd(c.x[i]), yi = _mm256_set1_pd(c.y[i]), zi = _mm256_set1_pd(c.z[i]);
  const __m256d e2 = _mm256_set1_pd(eps2);
  __m256d s = _mm256_setzero_pd();
  for (std::size_t j0 = (i + 1) / W * W; j0 < c.n; j0 += W) {
    const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(&c.x[j0]), xi);
    const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(&c.y[j0]), yi);
    const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(&c.z[j0]), zi);
    const __m256d r2 = _mm256_fmadd_pd(dz, dz, _mm256_fmadd_pd(dy, dy, _mm256_fmadd_pd(dx, dx, e2)));
    __m256d term = _mm256_div_pd(_mm256_loadu_pd(&c.m[j0]), _mm256_sqrt_pd(r2));
    if (j0 <= i || j0 + W > c.n) term = _mm256_and_pd(term, lanes_in(j0, i + 1, c.n));   // j > i, no padding
    s = _mm256_add_pd(s, term);
  }
  return lane_sum(s);
}

// ---------------------------------------------------------------------------------------------
// AVX-512 kernels: the AVX2 loops eight j at a time (lane k takes j = 8q + k), with the lanes kept as a
// bit mask. Lanes are added in a fixed order at the end of a row. 1 / r2^{3/2} comes from a refined
// reciprocal square root (gravity_avx512.hpp: within a few units in the last place), not from the divider.
// ---------------------------------------------------------------------------------------------
// GCC 12's avx512fintrin.h fills "undefined" vectors by self-initialisation, which -Wuninitialized flags.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
using gravity_avx512::inverse_cube;
constexpr std::size_t W8 = 8;

// Lanes j0 .. j0 + 7 with first <= j < end, as bits 0 .. 7.
inline __mmask8 lanes8_in(std::size_t j0, std::size_t first, std::size_t end) {
  const unsigned from = first <= j0 ? 0xffu : first - j0 < W8 ? 0xffu << (first - j0) : 0u;
  const unsigned below = end >= j0 + W8 ? 0xffu : end > j0 ? (1u << (end - j0)) - 1 : 0u;
  return __mmask8(from & below & 0xffu);
}

struct Row8 {
  __m512d x, y, z, m, eps2;
  __m512d sx, sy, sz;
};

// Pairs (i, j0 .. j0 + 7) into both sides; with `masked`, lanes outside `keep` add nothing (self, padding).
template <bool masked>
GRAINS_AVX512 inline void add_pairs8(const Columns& c, std::size_t j0, __mmask8 keep, Row8& r, Sums sj) {
  const __m512d dx = _mm512_sub_pd(_mm512_loadu_pd(&c.x[j0]), r.x);
  const __m512d dy = _mm512_sub_pd(_mm512_loadu_pd(&c.y[j0]), r.y);
  const __m512d dz = _mm512_sub_pd(_mm512_loadu_pd(&c.z[j0]), r.z);
  __m512d r2 = _mm512_fmadd_pd(dx, dx, r.eps2);
  r2 = _mm512_fmadd_pd(dy, dy, r2);
  r2 = _mm512_fmadd_pd(dz, dz, r2);
  __m512d t = inverse_cube(r2);
  if constexpr (masked) t = _mm512_maskz_mov_pd(keep, t);   // also clears NaN from r2 = 0 (self, eps = 0)
  const __m512d wi = _mm512_mul_pd(_mm512_loadu_pd(&c.m[j0]), t), wj = _mm512_mul_pd(r.m, t);
  r.sx = _mm512_fmadd_pd(wi, dx, r.sx), r.sy = _mm512_fmadd_pd(wi, dy, r.sy), r.sz = _mm512_fmadd_pd(wi, dz, r.sz);
  double *x = &sj.x[j0 - sj.first], *y = &sj.y[j0 - sj.first], *z = &sj.z[j0 - sj.first];
  _mm512_storeu_pd(x, _mm512_fnmadd_pd(wj, dx, _mm512_loadu_pd(x)));
  _mm512_storeu_pd(y, _mm512_fnmadd_pd(wj, dy, _mm512_loadu_pd(y)));
  _mm512_storeu_pd(z, _mm512_fnmadd_pd(wj, dz, _mm512_loadu_pd(z)));
}

// The j side is walked in chunks of `j_chunk` particles, each against every row of block I: a chunk's
// coordinates, masses and sums (7 x 8 bytes each, 28 KB) stay in the first-level cache, which a whole
// block (up to n / 16 particles) outgrows from n ~ 10^4 on. Row i's sum is then the chunks' partial sums in
// chunk order: still an order set by n alone.
constexpr std::size_t j_chunk = 512;   // a multiple of 8, so chunks start on a vector

GRAINS_AVX512 void tile_avx512(const Columns& c, double eps2, std::size_t I, std::size_t J, Sums si, Sums sj) {
  const std::size_t B = c.block;   // a multiple of 8: the last vector of a block stays inside the padding
  const std::size_t i1 = std::min(I * B + B, c.n), j1 = std::min(J * B + B, (c.n + W8 - 1) / W8 * W8);
  for (std::size_t jc = J * B; jc < j1; jc += j_chunk) {
    const std::size_t jc1 = std::min(jc + j_chunk, j1);
    for (std::size_t i = I * B; i < i1; ++i) {
      const std::size_t first = std::max(I == J ? i + 1 : J * B, jc);
      if (first >= jc1) continue;
      Row8 r{_mm512_set1_pd(c.x[i]), _mm512_set1_pd(c.y[i]), _mm512_set1_pd(c.z[i]), _mm512_set1_pd(c.m[i]),
             _mm512_set1_pd(eps2), _mm512_setzero_pd(), _mm512_setzero_pd(), _mm512_setzero_pd()};
      for (std::size_t j0 = first / W8 * W8; j0 < jc1; j0 += W8) {
        if (j0 < first || j0 + W8 > c.n)
          add_pairs8<true>(c, j0, lanes8_in(j0, first, c.n), r, sj);
        else
          add_pairs8<false>(c, j0, 0, r, sj);
      }
      si.x[i - si.first] += gravity_avx512::lane_sum(r.sx), si.y[i - si.first] += gravity_avx512::lane_sum(r.sy),
          si.z[i - si.first] += gravity_avx512::lane_sum(r.sz);
    }
  }
}

// The potential is needed at output times only: correctly rounded square root and division, as in AVX2.
GRAINS_AVX512 double potential_row_avx512(const Columns& c, double eps2, std::size_t i) {
  const __m512d xi = _mm512_set1_pd(c.x[i]), yi = _mm512_set1_pd(c.y[i]), zi = _mm512_set1_pd(c.z[i]);
  const __m512d e2 = _mm512_set1_pd(eps2);
  __m512d s = _mm512_setzero_pd();
  for (std::size_t j0 = (i + 1) / W8 * W8; j0 < c.n; j0 += W8) {
    const __m512d dx = _mm512_sub_pd(_mm512_loadu_pd(&c.x[j0]), xi);
    const __m512d dy = _mm512_sub_pd(_mm512_loadu_pd(&c.y[j0]), yi);
    const __m512d dz = _mm512_sub_pd(_mm512_loadu_pd(&c.z[j0]), zi);
    const __m512d r2 = _mm512_fmadd_pd(dz, dz, _mm512_fmadd_pd(dy, dy, _mm512_fmadd_pd(dx, dx, e2)));
    const __mmask8 keep = j0 <= i || j0 + W8 > c.n ? lanes8_in(j0, i + 1, c.n) : __mmask8(0xff);   // j > i, no padding
    s = _mm512_add_pd(s, _mm512_maskz_div_pd(keep, _mm512_loadu_pd(&c.m[j0]), _mm512_sqrt_pd(r2)));
  }
  return gravity_avx512::lane_sum(s);
}
#pragma GCC diagnostic pop

}  // namespace

void accelerations(Isa isa, const Columns& c, double eps2, int threads, std::vector<double>& ax, std::vector<double>& ay,
                   std::vector<double>& az) {
  // Task I takes the tiles (I, J >= I): block I's own sums (and the j side of the diagonal tile) go into
  // a{x,y,z} directly; the j side of tile (I, J > I) into its own slot of `spill`, added below in I order.
  // No task writes where another does, and a particle's terms are summed in an order set by n alone.
  const std::size_t S = c.block, blocks = c.x.size() / S;
  for (auto* a : {&ax, &ay, &az}) a->assign(c.x.size(), 0.0);
  auto slot = [&](std::size_t I, std::size_t J) { return 3 * S * (I * (2 * blocks - I - 1) / 2 + J - I - 1); };
  std::vector<double> spill(3 * S * blocks * (blocks - 1) / 2, 0.0);
  auto* tile = isa == Isa::avx512 ? tile_avx512 : isa == Isa::avx2 ? tile_avx2 : tile_portable;
  // Task I costs blocks - I - 1/2 tiles: handed out in that (decreasing) order, they balance the threads.
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
  for (std::size_t I = 0; I < blocks; ++I) {
    const Sums own{ax.data(), ay.data(), az.data(), 0};
    tile(c, eps2, I, I, own, own);
    for (std::size_t J = I + 1; J < blocks; ++J) {
      double* s = &spill[slot(I, J)];
      tile(c, eps2, I, J, own, Sums{s, s + S, s + 2 * S, J * S});
    }
  }
  // Serial: n (blocks - 1) / 2 additions per axis, and no second parallel region to start.
  for (std::size_t J = 1; J < blocks; ++J)
    for (std::size_t I = 0; I < J; ++I) {
      const double* s = &spill[slot(I, J)];
      for (std::size_t k = 0; k < S; ++k) ax[J * S + k] += s[k], ay[J * S + k] += s[S + k], az[J * S + k] += s[2 * S + k];
    }
  for (auto* a : {&ax, &ay, &az}) a->resize(c.n);
}

double potential(Isa isa, const Columns& c, double eps2, int threads) {
  std::vector<double> row(c.n, 0.0);
  auto* row_sum = isa == Isa::avx512 ? potential_row_avx512 : isa == Isa::avx2 ? potential_row_avx2 : potential_row_portable;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 16)
  for (std::size_t i = 0; i < c.n; ++i) row[i] = c.m[i] * row_sum(c, eps2, i);
  double energy = 0;
  for (double r : row) energy -= r;
  return energy;
}

}  // namespace grains::gravity_direct
