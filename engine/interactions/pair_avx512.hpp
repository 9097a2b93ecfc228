// AVX-512 pieces shared by the pair loop's kernels (pair_filter_avx512.cpp; cohesive_contacts_kernel.hpp and
// linear_contacts_kernel.hpp at eight lanes) and the neighbour build's candidate test (candidate_test_avx512.cpp): eight
// doubles per vector, one lane per list entry or grid slot. They are compiled for AVX-512 whatever the
// build flags (the binary stays portable x86-64): call them only from GRAINS_AVX512_PAIRS functions, and
// those only where pair_filter::avx512() is true. Include this header only in files compiled without
// multiply-add contraction (engine/CMakeLists.txt), so that every lane does the portable code's operations.
#pragma once
#include <cstddef>
#include <cstdint>

#include <immintrin.h>

#include "core/vec.hpp"

// GCC's own conversion, permutation and gather intrinsics start from an "undefined" vector it then warns about.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"

// popcnt: every AVX-512 processor has it (without it, __builtin_popcount is a library call).
#define GRAINS_AVX512_PAIRS __attribute__((target("avx512f,avx512vl,avx512bw,avx512dq,avx2,popcnt")))

namespace grains::pair_avx512 {

template <int D, bool Dense, bool Loads>
struct Contacts8;
template <int D>
struct ImageShifts;

// The operations of the kernels written once for both widths (cohesive_contacts_kernel.hpp,
// linear_contacts_kernel.hpp), at eight lanes; pair_avx2.hpp's Width4 has the same ones at four. A mask is a
// mask register; blend(m, a, op(...)) compiles to one masked instruction (op on the lanes of m only).
struct Width8 {
  static constexpr int lanes = 8;
  using V = __m512d;
  using Mask = __mmask8;
  template <int D, bool Dense = false, bool Loads = false>
  using Contacts = Contacts8<D, Dense, Loads>;
  template <int D>
  using Shifts = ImageShifts<D>;

  GRAINS_AVX512_PAIRS static V add(V a, V b) { return _mm512_add_pd(a, b); }
  GRAINS_AVX512_PAIRS static V sub(V a, V b) { return _mm512_sub_pd(a, b); }
  GRAINS_AVX512_PAIRS static V mul(V a, V b) { return _mm512_mul_pd(a, b); }
  GRAINS_AVX512_PAIRS static V div(V a, V b) { return _mm512_div_pd(a, b); }
  GRAINS_AVX512_PAIRS static V sqrt(V a) { return _mm512_sqrt_pd(a); }
  GRAINS_AVX512_PAIRS static V min(V a, V b) { return _mm512_min_pd(a, b); }
  GRAINS_AVX512_PAIRS static V max(V a, V b) { return _mm512_max_pd(a, b); }
  GRAINS_AVX512_PAIRS static V all(double a) { return _mm512_set1_pd(a); }
  GRAINS_AVX512_PAIRS static V zero() { return _mm512_setzero_pd(); }
  GRAINS_AVX512_PAIRS static V abs(V a) { return _mm512_abs_pd(a); }
  // -a, exactly (a sign flip, as unary minus).
  GRAINS_AVX512_PAIRS static V neg(V a) { return _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(a), sign_bit())); }
  // std::copysign(magnitude, sign).
  GRAINS_AVX512_PAIRS static V copysign(V magnitude, V sign) {
    return _mm512_castsi512_pd(_mm512_or_si512(_mm512_andnot_si512(sign_bit(), _mm512_castpd_si512(magnitude)),
                                               _mm512_and_si512(_mm512_castpd_si512(sign), sign_bit())));
  }

  // Masks. blend(m, a, b) takes b where m is set.
  GRAINS_AVX512_PAIRS static V blend(Mask m, V a, V b) { return _mm512_mask_blend_pd(m, a, b); }
  GRAINS_AVX512_PAIRS static Mask less(V a, V b) { return _mm512_cmp_pd_mask(a, b, _CMP_LT_OQ); }
  GRAINS_AVX512_PAIRS static Mask less_equal(V a, V b) { return _mm512_cmp_pd_mask(a, b, _CMP_LE_OQ); }
  GRAINS_AVX512_PAIRS static Mask greater(V a, V b) { return _mm512_cmp_pd_mask(a, b, _CMP_GT_OQ); }
  static Mask both(Mask m, Mask n) { return Mask(m & n); }
  static Mask either(Mask m, Mask n) { return Mask(m | n); }
  static Mask but_not(Mask m, Mask n) { return Mask(m & ~n); }
  static bool any(Mask m) { return m != 0; }
  GRAINS_AVX512_PAIRS static int count(Mask m) { return __builtin_popcount(m); }

  // The lanes' a[idx] (zero where m is clear).
  GRAINS_AVX512_PAIRS static V gather(const double* a, __m256i idx, Mask m) {
    return _mm512_mask_i32gather_pd(_mm512_setzero_pd(), m, idx, a, 8);
  }
  // The lanes' mask: all eight, or the first `left` of them.
  static Mask first_lanes(std::size_t left) { return left >= 8 ? Mask(0xFF) : Mask((1u << left) - 1); }

 private:
  GRAINS_AVX512_PAIRS static __m512i sign_bit() { return _mm512_set1_epi64(static_cast<long long>(0x8000000000000000ULL)); }
};

using V = Width8::V;

// The 2D vectors of eight particles, a[2 idx[l]] and a[2 idx[l] + 1] for l = 0 .. 7, as x and y components:
// eight 16-byte loads, transposed, where two gathers would load every lane's line twice. Used for the positions
// of the dense cohesive kernel (about 2.5 % of its force evaluation on the cohesive bench disks), and for the
// velocities as well where pair_filter::vector_loads() says (Contacts8's Loads): on the Xeon that measured slower
// (the loads' shuffles compete with the kernel's own for one port), on Zen 4 faster.
// Stride 3: the first two components of the 3D vectors a[3 idx[l] ..] (the pair filter's positions, where
// pair_filter::vector_loads() says).
template <int Stride = 2>
GRAINS_AVX512_PAIRS inline void load_2d(const double* a, const std::uint32_t* idx, V& x, V& y) {
  const auto two = [&](int l) GRAINS_AVX512_PAIRS {
    return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(a + Stride * std::size_t(idx[l]))),
                                _mm_loadu_pd(a + Stride * std::size_t(idx[l + 1])), 1);
  };
  const V low = _mm512_insertf64x4(_mm512_castpd256_pd512(two(0)), two(2), 1);   // x0 y0 x1 y1 x2 y2 x3 y3
  const V high = _mm512_insertf64x4(_mm512_castpd256_pd512(two(4)), two(6), 1);
  x = _mm512_permutex2var_pd(low, _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), high);
  y = _mm512_permutex2var_pd(low, _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15), high);
}

// Of the touching lanes (list entries k), those that touched at the last evaluation too (stamp + 1 ==
// evaluation; the contact's first step otherwise), restamped with this evaluation. Dense: the lanes' k
// are consecutive, from k0 (the shell's slots, contact_forces.hpp): loads and stores instead of a gather
// and a scatter.
template <bool Dense = false>
GRAINS_AVX512_PAIRS inline __mmask8 steady_contacts(__mmask8 touching, __m256i k, std::uint32_t k0, std::uint32_t* touched,
                                                    std::uint32_t evaluation) {
  const __m256i now = _mm256_set1_epi32(int(evaluation));
  const __m256i stamp = Dense ? _mm256_maskz_loadu_epi32(touching, touched + k0)
                              : _mm256_mmask_i32gather_epi32(_mm256_setzero_si256(), touching, k, touched, 4);
  const __mmask8 steady = _mm256_mask_cmpeq_epi32_mask(touching, _mm256_add_epi32(stamp, _mm256_set1_epi32(1)), now);
  if constexpr (Dense) _mm256_mask_storeu_epi32(touched + k0, steady, now);
  else _mm256_mask_i32scatter_epi32(touched, steady, k, now, 4);
  return steady;
}

// The periodic image shifts of the neighbour list (shift[s], s = sum (k_a + 1) 3^a), component by component,
// looked up by permutation rather than gathered. In 2D the nine shifts of an axis fill two registers, indexed
// by s itself (lanes 0-7 and 8 of shift[s][a]); in 3D axis a's register holds shift[d 3^a][a] in lanes d = 0,
// 1, 2 (the same value: a shift's component depends on its own axis's digit only), looked up by s's digits.
template <int D>
struct ImageShifts {
  V table[D][2];
  GRAINS_AVX512_PAIRS explicit ImageShifts(const Vec<D>* shift) {
    for (int a = 0; a < D; ++a) {
      if constexpr (D == 2) {
        table[a][0] = _mm512_setr_pd(shift[0][a], shift[1][a], shift[2][a], shift[3][a], shift[4][a], shift[5][a], shift[6][a],
                                     shift[7][a]);
        table[a][1] = _mm512_setr_pd(shift[8][a], 0, 0, 0, 0, 0, 0, 0);
      } else {
        const int unit = a == 0 ? 1 : a == 1 ? 3 : 9;
        table[a][0] = table[a][1] = _mm512_setr_pd(shift[0][a], shift[unit][a], shift[2 * unit][a], 0, 0, 0, 0, 0);
      }
    }
  }
  // Components of shift[s] for the lanes' image indices s (s < 3^D; in 3D, s / 3 = (11 s) >> 5 is exact there).
  GRAINS_AVX512_PAIRS void lookup(__m256i s, V out[D]) const {
    if constexpr (D == 2) {
      const __m512i index = _mm512_cvtepu32_epi64(s);
      for (int a = 0; a < D; ++a) out[a] = _mm512_permutex2var_pd(table[a][0], index, table[a][1]);
    } else {
      const __m256i three = _mm256_set1_epi32(3), eleven = _mm256_set1_epi32(11);
      __m256i rest = s;
      for (int a = 0; a < D; ++a) {
        const __m256i next = _mm256_srli_epi32(_mm256_mullo_epi32(rest, eleven), 5);
        const __m256i digit = a == D - 1 ? rest : _mm256_sub_epi32(rest, _mm256_mullo_epi32(next, three));
        out[a] = _mm512_permutexvar_pd(_mm512_cvtepu32_epi64(digit), table[a][0]);
        rest = next;
      }
    }
  }
};

// Particle index times D, the lanes' offsets into the D-vectors of the particle arrays (a shift and an
// addition: a multiplication of 32-bit lanes takes ten cycles and the gathers wait for it).
template <int D>
GRAINS_AVX512_PAIRS inline __m256i times_dim(__m256i i) {
  const __m256i twice = _mm256_slli_epi32(i, 1);
  return D == 2 ? twice : _mm256_add_epi32(twice, i);
}

// The geometry of eight gathered pairs q .. q + 7 (rows[q], list entries pairs[q], images[q]; the first
// `left` of them live) and which of them touch and which are steady contacts (touching, and at the last
// evaluation too; restamped). Mirrors the pair loop: r = (x_j + shift) - x_i, d2 = (r_x^2 + r_y^2) + r_z^2
// (as Eigen sums it), touching when d2 < (R_i + R_j)^2. Lanes of indices i D and j D address the D-vectors
// of the particle arrays. Dense: the pairs' entries k are consecutive from k0 = pairs[q] (the shell's
// slots), so the per-entry data (partner, stamps, and the radii, slot_radius[0][k] = R_i and
// slot_radius[1][k] = R_j) are loaded, and in 2D a whole batch's positions too (load_2d). Its methods
// are the kernels' loads and stores for these lanes (pair_avx2.hpp's Contacts4 has the same ones). Loads (2D,
// Dense): vector_at_i and vector_at_j read a whole batch's vectors by load_2d too, not by gathers.
template <int D, bool Dense = false, bool Loads = false>
struct Contacts8 {
  using Mask = Width8::Mask;
  __m256i i, k, j, iD, jD;
  std::uint32_t k0;
  const std::uint32_t *row_ids, *partner_ids;   // the lanes' i and j as plain integers (Dense)
  Mask live;
  V r[D], d2, Ri, Rj, Rsum;
  Mask touching, steady;
  [[gnu::always_inline]] GRAINS_AVX512_PAIRS Contacts8(const std::uint32_t* rows, const std::uint32_t* pairs,
                                                       const std::uint8_t* images, std::size_t q, std::size_t left,
                                                       const std::uint32_t* partner, const ImageShifts<D>& shifts,
                                                       const double* position, const double* radius, std::uint32_t* touched,
                                                       std::uint32_t evaluation, const double* const* slot_radius = nullptr) {
    using W = Width8;
    static_assert(!Loads || (D == 2 && Dense));
    live = W::first_lanes(left);
    i = _mm256_maskz_loadu_epi32(live, rows + q);
    k = _mm256_maskz_loadu_epi32(live, pairs + q);
    k0 = pairs[q];
    row_ids = rows + q, partner_ids = Dense ? partner + k0 : nullptr;
    j = Dense ? _mm256_maskz_loadu_epi32(live, partner_ids)
              : _mm256_mmask_i32gather_epi32(_mm256_setzero_si256(), live, k, partner, 4);
    iD = times_dim<D>(i), jD = times_dim<D>(j);
    V s[D];
    shifts.lookup(_mm256_cvtepu8_epi32(_mm_maskz_loadu_epi8(live, images + q)), s);
    V xj[D], xi[D];
    if (D == 2 && Dense && live == 0xFF) {   // every lane's row and partner read as plain integers
      load_2d(position, partner_ids, xj[0], xj[1]), load_2d(position, row_ids, xi[0], xi[1]);
    } else {
      for (int a = 0; a < D; ++a) xj[a] = W::gather(position + a, jD, live), xi[a] = W::gather(position + a, iD, live);
    }
    for (int a = 0; a < D; ++a) {
      r[a] = W::sub(W::add(xj[a], s[a]), xi[a]);
      d2 = a == 0 ? W::mul(r[a], r[a]) : W::add(d2, W::mul(r[a], r[a]));
    }
    if constexpr (Dense) Ri = _mm512_maskz_loadu_pd(live, slot_radius[0] + k0), Rj = _mm512_maskz_loadu_pd(live, slot_radius[1] + k0);
    else Ri = W::gather(radius, i, live), Rj = W::gather(radius, j, live);
    Rsum = W::add(Ri, Rj);
    touching = _mm512_mask_cmp_pd_mask(live, d2, W::mul(Rsum, Rsum), _CMP_LT_OQ);
    steady = steady_contacts<Dense>(touching, k, k0, touched, evaluation);
  }

  // Particle data: the lanes' a[i] or a[j] (read on the lanes of m), their D-vectors a[D i + 0 .. D - 1].
  GRAINS_AVX512_PAIRS V at_i(const double* a, Mask m) const { return Width8::gather(a, i, m); }
  GRAINS_AVX512_PAIRS V at_j(const double* a, Mask m) const { return Width8::gather(a, j, m); }
  GRAINS_AVX512_PAIRS void vector_at_i(const double* a, V out[D]) const {
    if constexpr (Loads)
      if (live == 0xFF) return load_2d(a, row_ids, out[0], out[1]);
    for (int c = 0; c < D; ++c) out[c] = Width8::gather(a + c, iD, live);
  }
  GRAINS_AVX512_PAIRS void vector_at_j(const double* a, V out[D]) const {
    if constexpr (Loads)
      if (live == 0xFF) return load_2d(a, partner_ids, out[0], out[1]);
    for (int c = 0; c < D; ++c) out[c] = Width8::gather(a + c, jD, live);
  }

  // Per-entry data, a[k]: gathered, or loaded from a + k0 where the lanes' k are consecutive.
  GRAINS_AVX512_PAIRS V per_entry(const double* a) const {
    if constexpr (Dense) return _mm512_maskz_loadu_pd(live, a + k0);
    else return Width8::gather(a, k, live);
  }
  // a[k] = v on the lanes of m: scattered, or stored to a + k0. (`old`, what per_entry read, serves the AVX2 build.)
  GRAINS_AVX512_PAIRS void set_per_entry(double* a, Mask m, V v, V /*old*/) const {
    if constexpr (Dense) _mm512_mask_storeu_pd(a + k0, m, v);
    else _mm512_mask_i32scatter_pd(a, m, k, v, 8);
  }
  // The 3-vectors a[3 k + 0 .. 2] (the springs of spheres), and their stores on the lanes of m.
  GRAINS_AVX512_PAIRS void vector_per_entry(const double* a, V out[3]) const {
    static_assert(!Dense);
    const __m256i k3 = _mm256_mullo_epi32(k, _mm256_set1_epi32(3));
    for (int c = 0; c < 3; ++c) out[c] = Width8::gather(a + c, k3, live);
  }
  GRAINS_AVX512_PAIRS void set_vector_per_entry(double* a, Mask m, const V v[3]) const {
    const __m256i k3 = _mm256_mullo_epi32(k, _mm256_set1_epi32(3));
    for (int c = 0; c < 3; ++c) _mm512_mask_i32scatter_pd(a + c, m, k3, v[c], 8);
  }
  // a[k] = value on the lanes of m, one by one.
  GRAINS_AVX512_PAIRS void set_entries(std::uint32_t* a, Mask m, std::uint32_t value) const {
    alignas(32) std::uint32_t entry[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(entry), k);
    for (unsigned l = m; l; l &= l - 1) a[Dense ? k0 + __builtin_ctz(l) : entry[__builtin_ctz(l)]] = value;
  }

  // The batch's results, into its block of eight (Results8: q is a multiple of 8). store(block, m, v)
  // stores the lanes of m only; the bits of a block's masks are the lanes'.
  GRAINS_AVX512_PAIRS void store(double* block, V v) const { _mm512_store_pd(block, v); }
  GRAINS_AVX512_PAIRS void store(double* block, Mask m, V v) const { _mm512_mask_store_pd(block, m, v); }
  GRAINS_AVX512_PAIRS void store_partners(std::uint32_t* block) const { _mm256_storeu_si256(reinterpret_cast<__m256i*>(block), j); }
  void set_bits(std::uint8_t& block_mask, Mask m) const { block_mask = m; }
};

}  // namespace grains::pair_avx512
