// One vector of lanes per instruction set and precision, with what the tree's sums (gravity_tree_sums.inc)
// need beyond + - * (which the vector types take as they are): those sums are written once over these types.
// Each member is compiled for its own instruction set whatever the build flags (the binary stays portable
// x86-64); call them only from functions compiled for that set (GRAINS_AVX2, GRAINS_AVX512), and those only
// after gravity_direct::supported(...).
#pragma once
#include <cstddef>

#include <immintrin.h>

#include "interactions/gravity_avx512.hpp"

#define GRAINS_AVX2 __attribute__((target("avx2,fma")))

// GCC 12's avx512fintrin.h fills "undefined" vectors by self-initialisation, which -Wuninitialized flags.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace grains::lanes {

// The lanes j0 + k (k < width <= 16) with first <= j < end, as bits k.
inline unsigned kept_bits(std::size_t j0, std::size_t first, std::size_t end, std::size_t width) {
  const unsigned all = (1u << width) - 1;
  const unsigned from = first <= j0 ? all : first - j0 < width ? all << (first - j0) : 0u;
  const unsigned below = end >= j0 + width ? all : end > j0 ? (1u << (end - j0)) - 1 : 0u;
  return from & below & all;
}

// Members of every lane type: T (the vector), S (its scalar), width (lanes), zero, set1, load, store, fma (a b + c),
// fnma (c - a b), sqrt, inverse_sqrt (1 / sqrt(r2)), inverse_cube (1 / r2^{3/2}), keep (v in the lanes j0 + k
// with first <= j < end, 0 in the others: self and padding may hold 0 * inf), drop (0 in lane j0 + k with
// j = skip, if any), and for FP64 sum (the lanes added in a fixed order), for FP32 widen (lanes k and
// k + width / 2 added in FP64).

// AVX2 + FMA, four doubles: the correctly rounded square root and division.
struct Avx2F64 {
  using T = __m256d;
  using S = double;
  static constexpr std::size_t width = 4;
  GRAINS_AVX2 static T zero() { return _mm256_setzero_pd(); }
  GRAINS_AVX2 static T set1(S s) { return _mm256_set1_pd(s); }
  GRAINS_AVX2 static T load(const S* p) { return _mm256_loadu_pd(p); }
  GRAINS_AVX2 static void store(S* p, T v) { _mm256_storeu_pd(p, v); }
  GRAINS_AVX2 static T fma(T a, T b, T c) { return _mm256_fmadd_pd(a, b, c); }
  GRAINS_AVX2 static T fnma(T a, T b, T c) { return _mm256_fnmadd_pd(a, b, c); }
  GRAINS_AVX2 static T sqrt(T r2) { return _mm256_sqrt_pd(r2); }
  GRAINS_AVX2 static T inverse_sqrt(T r2) { return _mm256_div_pd(set1(1.0), _mm256_sqrt_pd(r2)); }
  GRAINS_AVX2 static T inverse_cube(T r2) { return _mm256_div_pd(set1(1.0), _mm256_mul_pd(r2, _mm256_sqrt_pd(r2))); }
  GRAINS_AVX2 static __m256i index(std::size_t j0) {
    return _mm256_add_epi64(_mm256_set1_epi64x(static_cast<long long>(j0)), _mm256_setr_epi64x(0, 1, 2, 3));
  }
  GRAINS_AVX2 static T keep(T v, std::size_t j0, std::size_t first, std::size_t end) {
    const __m256i j = index(j0);
    const __m256i from = _mm256_cmpgt_epi64(j, _mm256_set1_epi64x(static_cast<long long>(first) - 1));
    const __m256i below = _mm256_cmpgt_epi64(_mm256_set1_epi64x(static_cast<long long>(end)), j);
    return _mm256_and_pd(v, _mm256_castsi256_pd(_mm256_and_si256(from, below)));
  }
  GRAINS_AVX2 static T drop(T v, std::size_t j0, std::size_t skip) {
    const __m256i self = _mm256_cmpeq_epi64(index(j0), _mm256_set1_epi64x(static_cast<long long>(skip)));
    return _mm256_andnot_pd(_mm256_castsi256_pd(self), v);
  }
  GRAINS_AVX2 static double sum(T v) {
    const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));   // (0+2, 1+3)
    return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
  }
};

// AVX2 + FMA, eight floats: the correctly rounded square root and division, whose bits (unlike those of
// the reciprocal square root estimate) are the same on every maker's processor.
struct Avx2F32 {
  using T = __m256;
  using S = float;
  static constexpr std::size_t width = 8;
  GRAINS_AVX2 static T zero() { return _mm256_setzero_ps(); }
  GRAINS_AVX2 static T set1(S s) { return _mm256_set1_ps(s); }
  GRAINS_AVX2 static T load(const S* p) { return _mm256_loadu_ps(p); }
  GRAINS_AVX2 static void store(S* p, T v) { _mm256_storeu_ps(p, v); }
  GRAINS_AVX2 static T fma(T a, T b, T c) { return _mm256_fmadd_ps(a, b, c); }
  GRAINS_AVX2 static T fnma(T a, T b, T c) { return _mm256_fnmadd_ps(a, b, c); }
  GRAINS_AVX2 static T sqrt(T r2) { return _mm256_sqrt_ps(r2); }
  GRAINS_AVX2 static T inverse_sqrt(T r2) { return _mm256_div_ps(set1(1.0f), _mm256_sqrt_ps(r2)); }
  GRAINS_AVX2 static T inverse_cube(T r2) { return _mm256_div_ps(set1(1.0f), _mm256_mul_ps(r2, _mm256_sqrt_ps(r2))); }
  GRAINS_AVX2 static __m256i index(std::size_t j0) {
    return _mm256_add_epi32(_mm256_set1_epi32(int(j0)), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  }
  GRAINS_AVX2 static T keep(T v, std::size_t j0, std::size_t first, std::size_t end) {
    const __m256i j = index(j0);
    const __m256i from = _mm256_cmpgt_epi32(j, _mm256_set1_epi32(int(first) - 1));
    const __m256i below = _mm256_cmpgt_epi32(_mm256_set1_epi32(int(end)), j);
    return _mm256_and_ps(v, _mm256_castsi256_ps(_mm256_and_si256(from, below)));
  }
  GRAINS_AVX2 static T drop(T v, std::size_t j0, std::size_t skip) {
    const __m256i self = _mm256_cmpeq_epi32(index(j0), _mm256_set1_epi32(int(skip)));
    return _mm256_andnot_ps(_mm256_castsi256_ps(self), v);
  }
  GRAINS_AVX2 static __m256d widen(T v) {
    return _mm256_add_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(v)), _mm256_cvtps_pd(_mm256_extractf128_ps(v, 1)));
  }
};

// AVX-512, eight doubles: 1 / sqrt from the refined reciprocal square root of gravity_avx512.hpp (within a
// few units in the last place), not the divider; lanes kept by a bit mask.
struct Avx512F64 {
  using T = __m512d;
  using S = double;
  static constexpr std::size_t width = 8;
  GRAINS_AVX512 static T zero() { return _mm512_setzero_pd(); }
  GRAINS_AVX512 static T set1(S s) { return _mm512_set1_pd(s); }
  GRAINS_AVX512 static T load(const S* p) { return _mm512_loadu_pd(p); }
  GRAINS_AVX512 static void store(S* p, T v) { _mm512_storeu_pd(p, v); }
  GRAINS_AVX512 static T fma(T a, T b, T c) { return _mm512_fmadd_pd(a, b, c); }
  GRAINS_AVX512 static T fnma(T a, T b, T c) { return _mm512_fnmadd_pd(a, b, c); }
  GRAINS_AVX512 static T sqrt(T r2) { return _mm512_sqrt_pd(r2); }
  GRAINS_AVX512 static T inverse_sqrt(T r2) { return gravity_avx512::rsqrt(r2); }
  GRAINS_AVX512 static T inverse_cube(T r2) { return gravity_avx512::inverse_cube(r2); }
  GRAINS_AVX512 static T keep(T v, std::size_t j0, std::size_t first, std::size_t end) {
    return _mm512_maskz_mov_pd(__mmask8(kept_bits(j0, first, end, width)), v);
  }
  GRAINS_AVX512 static T drop(T v, std::size_t j0, std::size_t skip) {
    return skip >= j0 && skip < j0 + width ? _mm512_mask_mov_pd(v, __mmask8(1u << (skip - j0)), set1(0.0)) : v;
  }
  GRAINS_AVX512 static double sum(T v) { return gravity_avx512::lane_sum(v); }
};

// AVX-512, sixteen floats: 1 / sqrt from vrsqrt14ps and one Newton step (2^-14 -> ~1e-8, below FP32
// round-off).
struct Avx512F32 {
  using T = __m512;
  using S = float;
  static constexpr std::size_t width = 16;
  GRAINS_AVX512 static T zero() { return _mm512_setzero_ps(); }
  GRAINS_AVX512 static T set1(S s) { return _mm512_set1_ps(s); }
  GRAINS_AVX512 static T load(const S* p) { return _mm512_loadu_ps(p); }
  GRAINS_AVX512 static void store(S* p, T v) { _mm512_storeu_ps(p, v); }
  GRAINS_AVX512 static T fma(T a, T b, T c) { return _mm512_fmadd_ps(a, b, c); }
  GRAINS_AVX512 static T fnma(T a, T b, T c) { return _mm512_fnmadd_ps(a, b, c); }
  GRAINS_AVX512 static T sqrt(T r2) { return _mm512_sqrt_ps(r2); }
  GRAINS_AVX512 static T inverse_sqrt(T r2) {
    const T y = _mm512_rsqrt14_ps(r2);
    return _mm512_fmadd_ps(_mm512_mul_ps(set1(0.5f), y), _mm512_fnmadd_ps(_mm512_mul_ps(r2, y), y, set1(1.0f)), y);
  }
  GRAINS_AVX512 static T inverse_cube(T r2) {
    const T y = inverse_sqrt(r2);
    return _mm512_mul_ps(_mm512_mul_ps(y, y), y);
  }
  GRAINS_AVX512 static T keep(T v, std::size_t j0, std::size_t first, std::size_t end) {
    return _mm512_maskz_mov_ps(__mmask16(kept_bits(j0, first, end, width)), v);
  }
  GRAINS_AVX512 static T drop(T v, std::size_t j0, std::size_t skip) {
    return skip >= j0 && skip < j0 + width ? _mm512_mask_mov_ps(v, __mmask16(1u << (skip - j0)), set1(0.0f)) : v;
  }
  GRAINS_AVX512 static __m512d widen(T v) {
    const __m256 hi = _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(v), 1));
    return _mm512_add_pd(_mm512_cvtps_pd(_mm512_castps512_ps256(v)), _mm512_cvtps_pd(hi));
  }
};

}  // namespace grains::lanes

#pragma GCC diagnostic pop
