#include "interactions/gravity_tree.hpp"
#include "interactions/gravity_avx512.hpp"
#include "core/morton.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <immintrin.h>

namespace grains::gravity_tree {

namespace {

constexpr std::size_t W = 4;     // doubles per AVX2 vector
constexpr std::size_t W8 = 8;    // per AVX-512 vector; the lists are padded to whole ones
constexpr std::size_t W16 = 16;  // floats per AVX-512 vector (the FP32 cell lists)

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

// What one group needs: the particles to sum one by one (the group's own first, so member k is entry k)
// and the cells to use whole. Both are padded with zeros to whole vectors; the kernels mask the padding.
struct Lists {
  std::vector<double> x, y, z, m;                                  // particles
  std::vector<double> cx, cy, cz, cm, qxx, qxy, qxz, qyy, qyz, qzz;   // cells
  std::size_t particles = 0, cells = 0;
  // The vector kernels' FP32 copies (Tree::multipoles32_ and the particles' copies), used instead of the
  // FP64 ones when fp32_particles or fp32_cells: positions relative to (gx, gy, gz) in units of len, each
  // split into float hi + lo; masses in units of `mass`, quadrupoles in units of mass len^2. Padded to
  // whole 16-float vectors with zeros.
  bool fp32_particles = false, fp32_cells = false;
  double gx = 0, gy = 0, gz = 0, len = 1, mass = 1;
  std::vector<float> pxh, pxl, pyh, pyl, pzh, pzl, pm;
  std::vector<float> fxh, fxl, fyh, fyl, fzh, fzl, fm, fqxx, fqxy, fqxz, fqyy, fqyz, fqzz;

  void clear() {
    for (auto* v : {&x, &y, &z, &m, &cx, &cy, &cz, &cm, &qxx, &qxy, &qxz, &qyy, &qyz, &qzz}) v->clear();
    for (auto* v : {&pxh, &pxl, &pyh, &pyl, &pzh, &pzl, &pm}) v->clear();
  }
  void pad_particles() {
    if (fp32_particles) {
      particles = pxh.size();
      for (auto* v : {&pxh, &pxl, &pyh, &pyl, &pzh, &pzl, &pm}) v->resize((particles + W16 - 1) / W16 * W16, 0.0f);
      return;
    }
    particles = x.size();
    for (auto* v : {&x, &y, &z, &m}) v->resize((particles + W8 - 1) / W8 * W8, 0.0);
  }
  void pad_cells() {
    cells = cx.size();
    for (auto* v : {&cx, &cy, &cz, &cm, &qxx, &qxy, &qxz, &qyy, &qyz, &qzz}) v->resize((cells + W8 - 1) / W8 * W8, 0.0);
  }
  // The FP32 copies of the cells `ids`, instead of the FP64 ones.
  template <class Record32>
  void fill_cells_fp32(const std::vector<Record32>& records, const std::vector<int>& ids) {
    cells = ids.size();
    const std::size_t n = (cells + W16 - 1) / W16 * W16;
    const std::array v{&fxh, &fxl, &fyh, &fyl, &fzh, &fzl, &fm, &fqxx, &fqxy, &fqxz, &fqyy, &fqyz, &fqzz};
    for (auto* f : v) f->assign(n, 0.0f);
    for (std::size_t k = 0; k < cells; ++k) {
      const Record32& c = records[ids[k]];
      for (int f = 0; f < 13; ++f) (*v[f])[k] = c[f];
    }
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
  const double xi = L.x[self], yi = L.y[self], zi = L.z[self];
  Sums s;
  for (std::size_t j = 0; j < L.particles; ++j) {
    if (j == self) continue;
    const double dx = L.x[j] - xi, dy = L.y[j] - yi, dz = L.z[j] - zi;
    const double r2 = dx * dx + dy * dy + dz * dz + eps2;
    const double w = L.m[j] / (r2 * std::sqrt(r2));
    s.x += w * dx, s.y += w * dy, s.z += w * dz, s.phi -= w * r2;
  }
  return s;
}

// Monopole + quadrupole of the softened kernel: with r = com - x and h = sqrt(|r|^2 + eps^2),
// phi = -(M / h + r.Q.r / (2 h^5)), a = (M / h^3 + 5/2 (r.Q.r) / h^7) r - Q r / h^5.
void cell_sums_portable(const Lists& L, double xi, double yi, double zi, double eps2, Sums& s) {
  for (std::size_t j = 0; j < L.cells; ++j) {
    const double dx = L.cx[j] - xi, dy = L.cy[j] - yi, dz = L.cz[j] - zi;
    const double inv = 1.0 / std::sqrt(dx * dx + dy * dy + dz * dz + eps2);
    const double inv2 = inv * inv, inv3 = inv * inv2, inv5 = inv3 * inv2;
    const double qx = L.qxx[j] * dx + L.qxy[j] * dy + L.qxz[j] * dz;
    const double qy = L.qxy[j] * dx + L.qyy[j] * dy + L.qyz[j] * dz;
    const double qz = L.qxz[j] * dx + L.qyz[j] * dy + L.qzz[j] * dz;
    const double rQr = dx * qx + dy * qy + dz * qz;
    const double a = L.cm[j] * inv3 + 2.5 * rQr * inv5 * inv2;
    s.x += a * dx - inv5 * qx, s.y += a * dy - inv5 * qy, s.z += a * dz - inv5 * qz;
    s.phi -= L.cm[j] * inv + 0.5 * rQr * inv5;
  }
}

Sums sums_portable(const Lists& L, std::size_t self, double eps2) {
  Sums s = particle_sums_portable(L, self, eps2);
  cell_sums_portable(L, L.x[self], L.y[self], L.z[self], eps2, s);
  return s;
}

// ---------------------------------------------------------------------------------------------
// AVX2 + FMA kernels: the same sums, four list entries at a time (lanes added in a fixed order at the end).
// ---------------------------------------------------------------------------------------------
#define GRAINS_AVX2 __attribute__((target("avx2,fma")))

// Lanes j0 .. j0 + 3 with j < end and j != skip, as all ones / all zeros per lane.
GRAINS_AVX2 inline __m256d lanes_kept(std::size_t j0, std::size_t end, std::size_t skip) {
  const __m256i j = _mm256_add_epi64(_mm256_set1_epi64x(static_cast<long long>(j0)), _mm256_setr_epi64x(0, 1, 2, 3));
  const __m256i below = _mm256_cmpgt_epi64(_mm256_set1_epi64x(static_cast<long long>(end)), j);
  const __m256i self = _mm256_cmpeq_epi64(j, _mm256_set1_epi64x(static_cast<long long>(skip)));
  return _mm256_castsi256_pd(_mm256_andnot_si256(self, below));
}

GRAINS_AVX2 inline double lane_sum(__m256d v) {
  const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));   // (0+2, 1+3)
  return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}

// The FP32 sums of the AVX-512 kernels below (see there why FP32 serves), eight list entries at a time. 1 / h
// from the correctly rounded square root and division, not the reciprocal square root estimate, whose bits
// differ between processor makers: the results are the same on any AVX2 processor.
struct Sums32x8 {
  __m256 x, y, z, phi;
};

GRAINS_AVX2 inline Sums32x8 zero_sums32x8() {
  const __m256 zero = _mm256_setzero_ps();
  return Sums32x8{zero, zero, zero, zero};
}

// Float lanes j0 .. j0 + 7 with j < end and j != skip, as all ones / all zeros per lane.
GRAINS_AVX2 inline __m256 lanes8_kept_ps(std::size_t j0, std::size_t end, std::size_t skip) {
  const __m256i j = _mm256_add_epi32(_mm256_set1_epi32(int(j0)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  const __m256i below = _mm256_cmpgt_epi32(_mm256_set1_epi32(int(end)), j);
  const __m256i self = _mm256_cmpeq_epi32(j, _mm256_set1_epi32(int(skip)));
  return _mm256_castsi256_ps(_mm256_andnot_si256(self, below));
}

template <bool potential>
GRAINS_AVX2 void particle_sums_fp32_avx2(const Lists& L, std::size_t self, __m256 e2, Sums32x8& f) {
  const __m256 xh = _mm256_set1_ps(L.pxh[self]), yh = _mm256_set1_ps(L.pyh[self]), zh = _mm256_set1_ps(L.pzh[self]);
  const __m256 xl = _mm256_set1_ps(L.pxl[self]), yl = _mm256_set1_ps(L.pyl[self]), zl = _mm256_set1_ps(L.pzl[self]);
  const __m256 one = _mm256_set1_ps(1.0f);
  const std::size_t self_vector = self / 8 * 8;
  for (std::size_t j0 = 0; j0 < L.particles; j0 += 8) {
    const __m256 dx = _mm256_add_ps(_mm256_sub_ps(_mm256_loadu_ps(&L.pxh[j0]), xh), _mm256_sub_ps(_mm256_loadu_ps(&L.pxl[j0]), xl));
    const __m256 dy = _mm256_add_ps(_mm256_sub_ps(_mm256_loadu_ps(&L.pyh[j0]), yh), _mm256_sub_ps(_mm256_loadu_ps(&L.pyl[j0]), yl));
    const __m256 dz = _mm256_add_ps(_mm256_sub_ps(_mm256_loadu_ps(&L.pzh[j0]), zh), _mm256_sub_ps(_mm256_loadu_ps(&L.pzl[j0]), zl));
    const __m256 r2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_fmadd_ps(dx, dx, e2)));
    __m256 t = _mm256_div_ps(one, _mm256_mul_ps(r2, _mm256_sqrt_ps(r2)));
    if (j0 == self_vector || j0 + 8 > L.particles) t = _mm256_and_ps(t, lanes8_kept_ps(j0, L.particles, self));
    const __m256 w = _mm256_mul_ps(_mm256_loadu_ps(&L.pm[j0]), t);
    f.x = _mm256_fmadd_ps(w, dx, f.x), f.y = _mm256_fmadd_ps(w, dy, f.y), f.z = _mm256_fmadd_ps(w, dz, f.z);
    if constexpr (potential) f.phi = _mm256_fnmadd_ps(w, r2, f.phi);   // m / h = m t r2
  }
}

template <bool potential>
GRAINS_AVX2 void cell_sums_fp32_avx2(const Lists& L, float xh, float xl, float yh, float yl, float zh, float zl, __m256 e2,
                                     Sums32x8& f) {
  const __m256 xhv = _mm256_set1_ps(xh), yhv = _mm256_set1_ps(yh), zhv = _mm256_set1_ps(zh);
  const __m256 xlv = _mm256_set1_ps(xl), ylv = _mm256_set1_ps(yl), zlv = _mm256_set1_ps(zl);
  const __m256 one = _mm256_set1_ps(1.0f), half = _mm256_set1_ps(0.5f), five_halves = _mm256_set1_ps(2.5f);
  for (std::size_t j0 = 0; j0 < L.cells; j0 += 8) {
    const __m256 dx = _mm256_add_ps(_mm256_sub_ps(_mm256_loadu_ps(&L.fxh[j0]), xhv), _mm256_sub_ps(_mm256_loadu_ps(&L.fxl[j0]), xlv));
    const __m256 dy = _mm256_add_ps(_mm256_sub_ps(_mm256_loadu_ps(&L.fyh[j0]), yhv), _mm256_sub_ps(_mm256_loadu_ps(&L.fyl[j0]), ylv));
    const __m256 dz = _mm256_add_ps(_mm256_sub_ps(_mm256_loadu_ps(&L.fzh[j0]), zhv), _mm256_sub_ps(_mm256_loadu_ps(&L.fzl[j0]), zlv));
    const __m256 r2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_fmadd_ps(dx, dx, e2)));
    __m256 inv = _mm256_div_ps(one, _mm256_sqrt_ps(r2));
    if (j0 + 8 > L.cells) inv = _mm256_and_ps(inv, lanes8_kept_ps(j0, L.cells, L.cells));   // padding
    const __m256 inv2 = _mm256_mul_ps(inv, inv), inv3 = _mm256_mul_ps(inv, inv2), inv5 = _mm256_mul_ps(inv3, inv2);
    const __m256 qxx = _mm256_loadu_ps(&L.fqxx[j0]), qxy = _mm256_loadu_ps(&L.fqxy[j0]), qxz = _mm256_loadu_ps(&L.fqxz[j0]);
    const __m256 qyy = _mm256_loadu_ps(&L.fqyy[j0]), qyz = _mm256_loadu_ps(&L.fqyz[j0]), qzz = _mm256_loadu_ps(&L.fqzz[j0]);
    const __m256 qx = _mm256_fmadd_ps(qxz, dz, _mm256_fmadd_ps(qxy, dy, _mm256_mul_ps(qxx, dx)));
    const __m256 qy = _mm256_fmadd_ps(qyz, dz, _mm256_fmadd_ps(qyy, dy, _mm256_mul_ps(qxy, dx)));
    const __m256 qz = _mm256_fmadd_ps(qzz, dz, _mm256_fmadd_ps(qyz, dy, _mm256_mul_ps(qxz, dx)));
    const __m256 rQr = _mm256_fmadd_ps(dz, qz, _mm256_fmadd_ps(dy, qy, _mm256_mul_ps(dx, qx)));
    const __m256 M = _mm256_loadu_ps(&L.fm[j0]);
    const __m256 rQr_inv5 = _mm256_mul_ps(rQr, inv5);
    const __m256 a = _mm256_fmadd_ps(M, inv3, _mm256_mul_ps(five_halves, _mm256_mul_ps(rQr_inv5, inv2)));
    f.x = _mm256_fnmadd_ps(inv5, qx, _mm256_fmadd_ps(a, dx, f.x));
    f.y = _mm256_fnmadd_ps(inv5, qy, _mm256_fmadd_ps(a, dy, f.y));
    f.z = _mm256_fnmadd_ps(inv5, qz, _mm256_fmadd_ps(a, dz, f.z));
    if constexpr (potential) f.phi = _mm256_sub_ps(f.phi, _mm256_fmadd_ps(M, inv, _mm256_mul_ps(half, rQr_inv5)));
  }
}

// Float lanes k and k + 4 added in FP64, times `unit` (a power of two: exact), added to s.
GRAINS_AVX2 inline __m256d add_widened4(__m256d s, __m256 v, double unit) {
  const __m256d w = _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(v)), _mm256_cvtps_pd(_mm256_extractf128_ps(v, 1)));
  return _mm256_add_pd(s, _mm256_mul_pd(w, _mm256_set1_pd(unit)));
}

template <bool potential>
GRAINS_AVX2 void add_widened_avx2(const Lists& L, const Sums32x8& f, __m256d& sx, __m256d& sy, __m256d& sz, __m256d& sp) {
  const double il = 1 / L.len, unit_a = L.mass * il * il;
  sx = add_widened4(sx, f.x, unit_a), sy = add_widened4(sy, f.y, unit_a), sz = add_widened4(sz, f.z, unit_a);
  if constexpr (potential) sp = add_widened4(sp, f.phi, L.mass * il);
}

// The potential only when asked for (it costs a few operations per term).
template <bool potential>
GRAINS_AVX2 Sums sums_avx2(const Lists& L, std::size_t self, double eps2) {
  __m256d sx = _mm256_setzero_pd(), sy = sx, sz = sx, sp = sx;
  const double il = 1 / L.len;
  const __m256 e2_fp32 = _mm256_set1_ps(float(eps2 * il * il));
  if (L.fp32_particles) {   // then the cells are FP32 too
    Sums32x8 f = zero_sums32x8();
    particle_sums_fp32_avx2<potential>(L, self, e2_fp32, f);
    cell_sums_fp32_avx2<potential>(L, L.pxh[self], L.pxl[self], L.pyh[self], L.pyl[self], L.pzh[self], L.pzl[self], e2_fp32, f);
    add_widened_avx2<potential>(L, f, sx, sy, sz, sp);
    return Sums{lane_sum(sx), lane_sum(sy), lane_sum(sz), lane_sum(sp)};
  }
  const __m256d xi = _mm256_set1_pd(L.x[self]), yi = _mm256_set1_pd(L.y[self]), zi = _mm256_set1_pd(L.z[self]);
  const __m256d e2 = _mm256_set1_pd(eps2), one = _mm256_set1_pd(1.0);
  // Particles: the vector holding `self` and the last one are masked (self and padding would add 0 * inf).
  const std::size_t self_vector = self / W * W;
  for (std::size_t j0 = 0; j0 < L.particles; j0 += W) {
    const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(&L.x[j0]), xi);
    const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(&L.y[j0]), yi);
    const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(&L.z[j0]), zi);
    const __m256d r2 = _mm256_fmadd_pd(dz, dz, _mm256_fmadd_pd(dy, dy, _mm256_fmadd_pd(dx, dx, e2)));
    __m256d t = _mm256_div_pd(one, _mm256_mul_pd(r2, _mm256_sqrt_pd(r2)));
    if (j0 == self_vector || j0 + W > L.particles) t = _mm256_and_pd(t, lanes_kept(j0, L.particles, self));
    const __m256d w = _mm256_mul_pd(_mm256_loadu_pd(&L.m[j0]), t);
    sx = _mm256_fmadd_pd(w, dx, sx), sy = _mm256_fmadd_pd(w, dy, sy), sz = _mm256_fmadd_pd(w, dz, sz);
    if constexpr (potential) sp = _mm256_fnmadd_pd(w, r2, sp);   // m / h = m t r2
  }
  if (L.fp32_cells) {
    const HiLo x = hi_lo(L.x[self], L.gx, il), y = hi_lo(L.y[self], L.gy, il), z = hi_lo(L.z[self], L.gz, il);
    Sums32x8 f = zero_sums32x8();
    cell_sums_fp32_avx2<potential>(L, x.hi, x.lo, y.hi, y.lo, z.hi, z.lo, e2_fp32, f);
    add_widened_avx2<potential>(L, f, sx, sy, sz, sp);
    return Sums{lane_sum(sx), lane_sum(sy), lane_sum(sz), lane_sum(sp)};
  }
  // Cells (portable kernel above for the formulas); the last vector is masked.
  const __m256d half = _mm256_set1_pd(0.5), five_halves = _mm256_set1_pd(2.5);
  for (std::size_t j0 = 0; j0 < L.cells; j0 += W) {
    const __m256d dx = _mm256_sub_pd(_mm256_loadu_pd(&L.cx[j0]), xi);
    const __m256d dy = _mm256_sub_pd(_mm256_loadu_pd(&L.cy[j0]), yi);
    const __m256d dz = _mm256_sub_pd(_mm256_loadu_pd(&L.cz[j0]), zi);
    const __m256d r2 = _mm256_fmadd_pd(dz, dz, _mm256_fmadd_pd(dy, dy, _mm256_fmadd_pd(dx, dx, e2)));
    __m256d inv = _mm256_div_pd(one, _mm256_sqrt_pd(r2));
    if (j0 + W > L.cells) inv = _mm256_and_pd(inv, lanes_kept(j0, L.cells, L.cells));
    const __m256d inv2 = _mm256_mul_pd(inv, inv), inv3 = _mm256_mul_pd(inv, inv2), inv5 = _mm256_mul_pd(inv3, inv2);
    const __m256d qxx = _mm256_loadu_pd(&L.qxx[j0]), qxy = _mm256_loadu_pd(&L.qxy[j0]), qxz = _mm256_loadu_pd(&L.qxz[j0]);
    const __m256d qyy = _mm256_loadu_pd(&L.qyy[j0]), qyz = _mm256_loadu_pd(&L.qyz[j0]), qzz = _mm256_loadu_pd(&L.qzz[j0]);
    const __m256d qx = _mm256_fmadd_pd(qxz, dz, _mm256_fmadd_pd(qxy, dy, _mm256_mul_pd(qxx, dx)));
    const __m256d qy = _mm256_fmadd_pd(qyz, dz, _mm256_fmadd_pd(qyy, dy, _mm256_mul_pd(qxy, dx)));
    const __m256d qz = _mm256_fmadd_pd(qzz, dz, _mm256_fmadd_pd(qyz, dy, _mm256_mul_pd(qxz, dx)));
    const __m256d rQr = _mm256_fmadd_pd(dz, qz, _mm256_fmadd_pd(dy, qy, _mm256_mul_pd(dx, qx)));
    const __m256d M = _mm256_loadu_pd(&L.cm[j0]);
    const __m256d rQr_inv5 = _mm256_mul_pd(rQr, inv5);
    const __m256d a = _mm256_fmadd_pd(M, inv3, _mm256_mul_pd(five_halves, _mm256_mul_pd(rQr_inv5, inv2)));
    sx = _mm256_fnmadd_pd(inv5, qx, _mm256_fmadd_pd(a, dx, sx));
    sy = _mm256_fnmadd_pd(inv5, qy, _mm256_fmadd_pd(a, dy, sy));
    sz = _mm256_fnmadd_pd(inv5, qz, _mm256_fmadd_pd(a, dz, sz));
    if constexpr (potential) sp = _mm256_sub_pd(sp, _mm256_fmadd_pd(M, inv, _mm256_mul_pd(half, rQr_inv5)));
  }
  return Sums{lane_sum(sx), lane_sum(sy), lane_sum(sz), lane_sum(sp)};
}

// ---------------------------------------------------------------------------------------------
// AVX-512 kernels: the AVX2 ones eight list entries at a time, lanes kept as a bit mask; 1 / sqrt(r2) from a
// refined reciprocal square root (gravity_avx512.hpp: within a few units in the last place), not the divider.
// ---------------------------------------------------------------------------------------------
// GCC 12's avx512fintrin.h fills "undefined" vectors by self-initialisation, which -Wuninitialized flags.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

// Lanes j0 .. j0 + 7 with j < end and j != skip, as bits 0 .. 7.
inline __mmask8 lanes8_kept(std::size_t j0, std::size_t end, std::size_t skip) {
  unsigned keep = end >= j0 + W8 ? 0xffu : end > j0 ? (1u << (end - j0)) - 1 : 0u;
  if (skip >= j0 && skip < j0 + W8) keep &= ~(1u << (skip - j0));
  return __mmask8(keep);
}

// Float lanes k and k + 8 added in FP64, times `unit` (a power of two: exact).
GRAINS_AVX512 inline __m512d widen(__m512 v, double unit) {
  const __m256 hi = _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1));
  return _mm512_mul_pd(_mm512_add_pd(_mm512_cvtps_pd(_mm512_castps512_ps256(v)), _mm512_cvtps_pd(hi)), _mm512_set1_pd(unit));
}

// Lanes j0 .. j0 + 15 with j < end and j != skip, as bits 0 .. 15.
inline __mmask16 lanes16_kept(std::size_t j0, std::size_t end, std::size_t skip) {
  unsigned keep = end >= j0 + W16 ? 0xffffu : end > j0 ? (1u << (end - j0)) - 1 : 0u;
  if (skip >= j0 && skip < j0 + W16) keep &= ~(1u << (skip - j0));
  return __mmask16(keep);
}

// The FP32 terms. FP32 is safe here: a cell term is an expansion whose truncation error is ~1e-4 relative at
// theta 0.5 (~1e-5 at theta 0.2; the tree's median force error is ~2e-4 at 0.5), and a particle's near field
// is one part of a sum carrying that error; FP32 rounding is ~1e-7 relative. Large coordinates lose nothing:
// positions are taken relative to the tree's origin in FP64 and split into float hi + lo, so
// (hi_j - hi_i) + (lo_j - lo_i) is the FP64 displacement to about FP32 precision however far from the
// origin. Lengths and masses are in power-of-two units (exact scaling) fitted to the tree, and the walk
// keeps FP64 where h could leave the range in which h^-7 and the like stay normal floats (Tree::evaluate).
// 1 / h: vrsqrt14ps and one Newton step (2^-14 -> ~1e-8, below FP32 round-off). Each particle's sums stay in
// FP32 lanes to the end of its lists (about a hundred terms a lane), then are widened, scaled back and
// summed in FP64 in a fixed order: deterministic. Measured against the FP64 kernels: within 1e-6 of each
// particle's acceleration (tests/engine/test_gravity.cpp, bound 4e-6).
struct Sums32 {
  __m512 x, y, z, phi;
};

GRAINS_AVX512 inline Sums32 zero_sums32() {
  const __m512 zero = _mm512_setzero_ps();
  return Sums32{zero, zero, zero, zero};
}

GRAINS_AVX512 inline __m512 rsqrt_fp32(__m512 r2) {
  const __m512 y = _mm512_rsqrt14_ps(r2);
  return _mm512_fmadd_ps(_mm512_mul_ps(_mm512_set1_ps(0.5f), y), _mm512_fnmadd_ps(_mm512_mul_ps(r2, y), y, _mm512_set1_ps(1.0f)), y);
}

// Particle `self` of the FP32 particle list against every other particle of it.
template <bool potential>
GRAINS_AVX512 void particle_sums_fp32(const Lists& L, std::size_t self, __m512 e2, Sums32& f) {
  const __m512 xh = _mm512_set1_ps(L.pxh[self]), yh = _mm512_set1_ps(L.pyh[self]), zh = _mm512_set1_ps(L.pzh[self]);
  const __m512 xl = _mm512_set1_ps(L.pxl[self]), yl = _mm512_set1_ps(L.pyl[self]), zl = _mm512_set1_ps(L.pzl[self]);
  // The vector holding `self` and the last one are masked (self: a zero distance; padding: m = 0).
  const std::size_t self_vector = self / W16 * W16;
  for (std::size_t j0 = 0; j0 < L.particles; j0 += W16) {
    const __m512 dx = _mm512_add_ps(_mm512_sub_ps(_mm512_loadu_ps(&L.pxh[j0]), xh), _mm512_sub_ps(_mm512_loadu_ps(&L.pxl[j0]), xl));
    const __m512 dy = _mm512_add_ps(_mm512_sub_ps(_mm512_loadu_ps(&L.pyh[j0]), yh), _mm512_sub_ps(_mm512_loadu_ps(&L.pyl[j0]), yl));
    const __m512 dz = _mm512_add_ps(_mm512_sub_ps(_mm512_loadu_ps(&L.pzh[j0]), zh), _mm512_sub_ps(_mm512_loadu_ps(&L.pzl[j0]), zl));
    const __m512 r2 = _mm512_fmadd_ps(dz, dz, _mm512_fmadd_ps(dy, dy, _mm512_fmadd_ps(dx, dx, e2)));
    const __m512 inv = rsqrt_fp32(r2);
    __m512 t = _mm512_mul_ps(_mm512_mul_ps(inv, inv), inv);
    if (j0 == self_vector || j0 + W16 > L.particles) t = _mm512_maskz_mov_ps(lanes16_kept(j0, L.particles, self), t);
    const __m512 w = _mm512_mul_ps(_mm512_loadu_ps(&L.pm[j0]), t);
    f.x = _mm512_fmadd_ps(w, dx, f.x), f.y = _mm512_fmadd_ps(w, dy, f.y), f.z = _mm512_fmadd_ps(w, dz, f.z);
    if constexpr (potential) f.phi = _mm512_fnmadd_ps(w, r2, f.phi);   // m / h = m t r2
  }
}

// Cell terms (the portable kernel's formulas) at the point (xh + xl, yh + yl, zh + zl).
template <bool potential>
GRAINS_AVX512 void cell_sums_fp32(const Lists& L, float xh, float xl, float yh, float yl, float zh, float zl, __m512 e2,
                                  Sums32& f) {
  const __m512 xhv = _mm512_set1_ps(xh), yhv = _mm512_set1_ps(yh), zhv = _mm512_set1_ps(zh);
  const __m512 xlv = _mm512_set1_ps(xl), ylv = _mm512_set1_ps(yl), zlv = _mm512_set1_ps(zl);
  const __m512 half = _mm512_set1_ps(0.5f), five_halves = _mm512_set1_ps(2.5f);
  for (std::size_t j0 = 0; j0 < L.cells; j0 += W16) {
    const __m512 dx = _mm512_add_ps(_mm512_sub_ps(_mm512_loadu_ps(&L.fxh[j0]), xhv), _mm512_sub_ps(_mm512_loadu_ps(&L.fxl[j0]), xlv));
    const __m512 dy = _mm512_add_ps(_mm512_sub_ps(_mm512_loadu_ps(&L.fyh[j0]), yhv), _mm512_sub_ps(_mm512_loadu_ps(&L.fyl[j0]), ylv));
    const __m512 dz = _mm512_add_ps(_mm512_sub_ps(_mm512_loadu_ps(&L.fzh[j0]), zhv), _mm512_sub_ps(_mm512_loadu_ps(&L.fzl[j0]), zlv));
    const __m512 r2 = _mm512_fmadd_ps(dz, dz, _mm512_fmadd_ps(dy, dy, _mm512_fmadd_ps(dx, dx, e2)));
    __m512 inv = rsqrt_fp32(r2);
    if (j0 + W16 > L.cells) inv = _mm512_maskz_mov_ps(__mmask16((1u << (L.cells - j0)) - 1), inv);   // padding
    const __m512 inv2 = _mm512_mul_ps(inv, inv), inv3 = _mm512_mul_ps(inv, inv2), inv5 = _mm512_mul_ps(inv3, inv2);
    const __m512 qxx = _mm512_loadu_ps(&L.fqxx[j0]), qxy = _mm512_loadu_ps(&L.fqxy[j0]), qxz = _mm512_loadu_ps(&L.fqxz[j0]);
    const __m512 qyy = _mm512_loadu_ps(&L.fqyy[j0]), qyz = _mm512_loadu_ps(&L.fqyz[j0]), qzz = _mm512_loadu_ps(&L.fqzz[j0]);
    const __m512 qx = _mm512_fmadd_ps(qxz, dz, _mm512_fmadd_ps(qxy, dy, _mm512_mul_ps(qxx, dx)));
    const __m512 qy = _mm512_fmadd_ps(qyz, dz, _mm512_fmadd_ps(qyy, dy, _mm512_mul_ps(qxy, dx)));
    const __m512 qz = _mm512_fmadd_ps(qzz, dz, _mm512_fmadd_ps(qyz, dy, _mm512_mul_ps(qxz, dx)));
    const __m512 rQr = _mm512_fmadd_ps(dz, qz, _mm512_fmadd_ps(dy, qy, _mm512_mul_ps(dx, qx)));
    const __m512 M = _mm512_loadu_ps(&L.fm[j0]);
    const __m512 rQr_inv5 = _mm512_mul_ps(rQr, inv5);
    const __m512 a = _mm512_fmadd_ps(M, inv3, _mm512_mul_ps(five_halves, _mm512_mul_ps(rQr_inv5, inv2)));
    f.x = _mm512_fnmadd_ps(inv5, qx, _mm512_fmadd_ps(a, dx, f.x));
    f.y = _mm512_fnmadd_ps(inv5, qy, _mm512_fmadd_ps(a, dy, f.y));
    f.z = _mm512_fnmadd_ps(inv5, qz, _mm512_fmadd_ps(a, dz, f.z));
    if constexpr (potential) f.phi = _mm512_sub_ps(f.phi, _mm512_fmadd_ps(M, inv, _mm512_mul_ps(half, rQr_inv5)));
  }
}

// FP32 lane sums added to FP64 ones: accelerations in units of mass / len^2, potentials of mass / len.
template <bool potential>
GRAINS_AVX512 void add_widened(const Lists& L, const Sums32& f, __m512d& sx, __m512d& sy, __m512d& sz, __m512d& sp) {
  const double il = 1 / L.len, unit_a = L.mass * il * il;
  sx = _mm512_add_pd(sx, widen(f.x, unit_a)), sy = _mm512_add_pd(sy, widen(f.y, unit_a)), sz = _mm512_add_pd(sz, widen(f.z, unit_a));
  if constexpr (potential) sp = _mm512_add_pd(sp, widen(f.phi, L.mass * il));
}

template <bool potential>
GRAINS_AVX512 Sums sums_avx512(const Lists& L, std::size_t self, double eps2) {
  using gravity_avx512::inverse_cube, gravity_avx512::rsqrt, gravity_avx512::lane_sum;
  __m512d sx = _mm512_setzero_pd(), sy = sx, sz = sx, sp = sx;
  const double il = 1 / L.len;
  const __m512 e2_fp32 = _mm512_set1_ps(float(eps2 * il * il));
  if (L.fp32_particles) {   // then the cells are FP32 too
    Sums32 f = zero_sums32();
    particle_sums_fp32<potential>(L, self, e2_fp32, f);
    cell_sums_fp32<potential>(L, L.pxh[self], L.pxl[self], L.pyh[self], L.pyl[self], L.pzh[self], L.pzl[self], e2_fp32, f);
    add_widened<potential>(L, f, sx, sy, sz, sp);
    return Sums{lane_sum(sx), lane_sum(sy), lane_sum(sz), lane_sum(sp)};
  }
  const __m512d xi = _mm512_set1_pd(L.x[self]), yi = _mm512_set1_pd(L.y[self]), zi = _mm512_set1_pd(L.z[self]);
  const __m512d e2 = _mm512_set1_pd(eps2);
  // Particles: the vector holding `self` and the last one are masked (self: r2 may be 0; padding: m = 0).
  const std::size_t self_vector = self / W8 * W8;
  for (std::size_t j0 = 0; j0 < L.particles; j0 += W8) {
    const __m512d dx = _mm512_sub_pd(_mm512_loadu_pd(&L.x[j0]), xi);
    const __m512d dy = _mm512_sub_pd(_mm512_loadu_pd(&L.y[j0]), yi);
    const __m512d dz = _mm512_sub_pd(_mm512_loadu_pd(&L.z[j0]), zi);
    const __m512d r2 = _mm512_fmadd_pd(dz, dz, _mm512_fmadd_pd(dy, dy, _mm512_fmadd_pd(dx, dx, e2)));
    __m512d t = inverse_cube(r2);
    if (j0 == self_vector || j0 + W8 > L.particles) t = _mm512_maskz_mov_pd(lanes8_kept(j0, L.particles, self), t);
    const __m512d w = _mm512_mul_pd(_mm512_loadu_pd(&L.m[j0]), t);
    sx = _mm512_fmadd_pd(w, dx, sx), sy = _mm512_fmadd_pd(w, dy, sy), sz = _mm512_fmadd_pd(w, dz, sz);
    if constexpr (potential) sp = _mm512_fnmadd_pd(w, r2, sp);   // m / h = m t r2
  }
  if (L.fp32_cells) {
    const HiLo x = hi_lo(L.x[self], L.gx, il), y = hi_lo(L.y[self], L.gy, il), z = hi_lo(L.z[self], L.gz, il);
    Sums32 f = zero_sums32();
    cell_sums_fp32<potential>(L, x.hi, x.lo, y.hi, y.lo, z.hi, z.lo, e2_fp32, f);
    add_widened<potential>(L, f, sx, sy, sz, sp);
    return Sums{lane_sum(sx), lane_sum(sy), lane_sum(sz), lane_sum(sp)};
  }
  // Cells in FP64 (portable kernel above for the formulas); the last vector is masked.
  const __m512d half = _mm512_set1_pd(0.5), five_halves = _mm512_set1_pd(2.5);
  for (std::size_t j0 = 0; j0 < L.cells; j0 += W8) {
    const __m512d dx = _mm512_sub_pd(_mm512_loadu_pd(&L.cx[j0]), xi);
    const __m512d dy = _mm512_sub_pd(_mm512_loadu_pd(&L.cy[j0]), yi);
    const __m512d dz = _mm512_sub_pd(_mm512_loadu_pd(&L.cz[j0]), zi);
    const __m512d r2 = _mm512_fmadd_pd(dz, dz, _mm512_fmadd_pd(dy, dy, _mm512_fmadd_pd(dx, dx, e2)));
    __m512d inv = rsqrt(r2);
    if (j0 + W8 > L.cells) inv = _mm512_maskz_mov_pd(lanes8_kept(j0, L.cells, L.cells), inv);
    const __m512d inv2 = _mm512_mul_pd(inv, inv), inv3 = _mm512_mul_pd(inv, inv2), inv5 = _mm512_mul_pd(inv3, inv2);
    const __m512d qxx = _mm512_loadu_pd(&L.qxx[j0]), qxy = _mm512_loadu_pd(&L.qxy[j0]), qxz = _mm512_loadu_pd(&L.qxz[j0]);
    const __m512d qyy = _mm512_loadu_pd(&L.qyy[j0]), qyz = _mm512_loadu_pd(&L.qyz[j0]), qzz = _mm512_loadu_pd(&L.qzz[j0]);
    const __m512d qx = _mm512_fmadd_pd(qxz, dz, _mm512_fmadd_pd(qxy, dy, _mm512_mul_pd(qxx, dx)));
    const __m512d qy = _mm512_fmadd_pd(qyz, dz, _mm512_fmadd_pd(qyy, dy, _mm512_mul_pd(qxy, dx)));
    const __m512d qz = _mm512_fmadd_pd(qzz, dz, _mm512_fmadd_pd(qyz, dy, _mm512_mul_pd(qxz, dx)));
    const __m512d rQr = _mm512_fmadd_pd(dz, qz, _mm512_fmadd_pd(dy, qy, _mm512_mul_pd(dx, qx)));
    const __m512d M = _mm512_loadu_pd(&L.cm[j0]);
    const __m512d rQr_inv5 = _mm512_mul_pd(rQr, inv5);
    const __m512d a = _mm512_fmadd_pd(M, inv3, _mm512_mul_pd(five_halves, _mm512_mul_pd(rQr_inv5, inv2)));
    sx = _mm512_fnmadd_pd(inv5, qx, _mm512_fmadd_pd(a, dx, sx));
    sy = _mm512_fnmadd_pd(inv5, qy, _mm512_fmadd_pd(a, dy, sy));
    sz = _mm512_fnmadd_pd(inv5, qz, _mm512_fmadd_pd(a, dz, sz));
    if constexpr (potential) sp = _mm512_sub_pd(sp, _mm512_fmadd_pd(M, inv, _mm512_mul_pd(half, rQr_inv5)));
  }
  return Sums{lane_sum(sx), lane_sum(sy), lane_sum(sz), lane_sum(sp)};
}

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
  // The FP32 copies only where the kernels may read them (Tree::evaluate).
  const bool fp32 = theta_ >= fp32_min_theta;
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
  // Adds m (3 d d^T - |d|^2 I) to Q.
  auto add = [&Q](double m, double dx, double dy, double dz) {
    const double d2 = dx * dx + dy * dy + dz * dz;
    Q[0] += m * (3 * dx * dx - d2), Q[1] += m * 3 * dx * dy, Q[2] += m * 3 * dx * dz;
    Q[3] += m * (3 * dy * dy - d2), Q[4] += m * 3 * dy * dz, Q[5] += m * (3 * dz * dz - d2);
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
  // convergence radius) even when the centre of mass sits near one edge.
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
              : isa == Isa::avx2    ? (phi ? sums_avx2<true> : sums_avx2<false>)
                                    : (phi ? sums_avx512<true> : sums_avx512<false>);
  // FP32 sums (cell_sums_fp32) where h / len lies in [1e-5, 1e5] for every pair summed (all lie within the
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
        auto add = [from, to](std::vector<float>& list, const std::vector<float>& v) {
          list.insert(list.end(), v.data() + from, v.data() + to);
        };
        if (L.fp32_particles) {
          add(L.pxh, xh_), add(L.pxl, xl_), add(L.pyh, yh_), add(L.pyl, yl_), add(L.pzh, zh_), add(L.pzl, zl_), add(L.pm, m32_);
          return;
        }
        L.x.insert(L.x.end(), x_.data() + from, x_.data() + to), L.y.insert(L.y.end(), y_.data() + from, y_.data() + to);
        L.z.insert(L.z.end(), z_.data() + from, z_.data() + to), L.m.insert(L.m.end(), m_.data() + from, m_.data() + to);
      };
      add_particles(b, e);
      // Cells used whole are noted during the walk and copied into the lists after it.
      used.clear();
      // The least squared distance of a used cell to the group's box.
      const double near2 = walk_of(nodes_, isa, groups_[g], lo, hi, stack, used, add_particles);
      L.pad_particles();
      const std::size_t u = used.size();
      L.fp32_cells = fp32_particles || (fp32 && u > 0 && (near2 + eps2) / (len_ * len_) >= 1e-10);
      if (L.fp32_cells) {
        L.fill_cells_fp32(multipoles32_, used);
      } else {
        for (auto* v : {&L.cx, &L.cy, &L.cz, &L.cm, &L.qxx, &L.qxy, &L.qxz, &L.qyy, &L.qyz, &L.qzz}) v->resize(u);
        for (std::size_t k = 0; k < u; ++k) {
          const Multipole& c = multipoles_[used[k]];
          L.cx[k] = c[0], L.cy[k] = c[1], L.cz[k] = c[2], L.cm[k] = c[3];
          L.qxx[k] = c[4], L.qxy[k] = c[5], L.qxz[k] = c[6], L.qyy[k] = c[7], L.qyz[k] = c[8], L.qzz[k] = c[9];
        }
        L.pad_cells();
      }
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
