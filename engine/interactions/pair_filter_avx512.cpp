// AVX-512 build of the pair filter (pair_filter.hpp). Compiled for AVX-512 whatever the build flags and
// without FMA contraction (engine/CMakeLists.txt), so each lane does the portable build's operations.
#include "interactions/pair_filter.hpp"

#include <atomic>
#include <cstdlib>
#include <cstring>

#include <immintrin.h>

// GCC's own _mm512_cvtepu32_epi64 and _mm512_permutexvar_pd start from an "undefined" vector it then warns about.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

#define GRAINS_AVX512_FILTER __attribute__((target("avx512f,avx512vl,avx512bw,avx2")))

namespace grains::pair_filter {

static_assert(sizeof(Vec<2>) == 2 * sizeof(double) && sizeof(Vec<3>) == 3 * sizeof(double), "positions are packed");

namespace {
std::atomic<bool> portable_preferred{false};
}

bool avx512() {
  static const bool available = [] {
    const char* want = std::getenv("GRAINS_PAIR_ISA");
    if (want && std::strcmp(want, "portable") == 0) return false;
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512dq");
  }();
  return available && !portable_preferred.load(std::memory_order_relaxed);
}

void prefer_portable(bool yes) { portable_preferred.store(yes, std::memory_order_relaxed); }

namespace {

// An image index s = sum (k_a + 1) 3^a (s < 27) split into its base-3 digits: s / 3 = (11 s) >> 5 is exact there.
GRAINS_AVX512_FILTER inline __m256i third(__m256i s) { return _mm256_srli_epi32(_mm256_mullo_epi32(s, _mm256_set1_epi32(11)), 5); }

// Component a of the image shifts by digit d (0, 1, 2) of axis a: shift[d 3^a][a] in lanes 0-2, looked up
// with a permutation rather than gathered.
template <int D>
GRAINS_AVX512_FILTER inline __m512d shift_table(const Vec<D>* shift, int a) {
  const int unit = a == 0 ? 1 : a == 1 ? 3 : 9;
  return _mm512_setr_pd(shift[0][a], shift[unit][a], shift[2 * unit][a], 0, 0, 0, 0, 0);
}

template <int D>
GRAINS_AVX512_FILTER std::size_t gather(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                                        std::uint32_t* pairs, std::uint8_t* images) {
  const double* x = g.position[0].data();
  const __m512d tail = _mm512_set1_pd(g.tail_reach), zero = _mm512_setzero_pd();
  const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7), dim = _mm256_set1_epi32(D), three = _mm256_set1_epi32(3);
  __m512d table[D];
  for (int a = 0; a < D; ++a) table[a] = shift_table<D>(g.shift, a);
  std::size_t n = 0;
  for (std::uint32_t k = k_begin; k < k_end; k += 8) {
    const __mmask8 live = k_end - k >= 8 ? __mmask8(0xFF) : __mmask8((1u << (k_end - k)) - 1);
    const __m256i j = _mm256_maskz_loadu_epi32(live, g.partner + k);
    const __m256i i = _mm256_maskz_loadu_epi32(live, g.owner + k);
    const __m256i s = _mm256_cvtepu8_epi32(_mm_maskz_loadu_epi8(live, g.image + k));
    const __m256i jx = _mm256_mullo_epi32(j, dim), ix = _mm256_mullo_epi32(i, dim);
    // Base-3 digits of the image index: x, then y, then (3D) z.
    const __m256i s1 = third(s);
    const __m256i digit_x = _mm256_sub_epi32(s, _mm256_mullo_epi32(s1, three));
    __m256i digit_y = s1, digit_z = _mm256_setzero_si256();
    if constexpr (D == 3) {
      const __m256i s2 = third(s1);
      digit_y = _mm256_sub_epi32(s1, _mm256_mullo_epi32(s2, three));
      digit_z = s2;
    }
    __m512d d2 = zero;
    for (int a = 0; a < D; ++a) {
      const __m512d xj = _mm512_mask_i32gather_pd(zero, live, jx, x + a, 8);
      const __m512d xi = _mm512_mask_i32gather_pd(zero, live, ix, x + a, 8);
      const __m256i digit = a == 0 ? digit_x : a == 1 ? digit_y : digit_z;
      const __m512d sh = _mm512_permutexvar_pd(_mm512_cvtepu32_epi64(digit), table[a]);
      const __m512d r = _mm512_sub_pd(_mm512_add_pd(xj, sh), xi);
      d2 = a == 0 ? _mm512_mul_pd(r, r) : _mm512_add_pd(d2, _mm512_mul_pd(r, r));   // (x^2 + y^2) + z^2
    }
    const __m512d Rj = _mm512_mask_i32gather_pd(zero, live, j, g.radius, 8);
    const __m512d Ri = _mm512_mask_i32gather_pd(zero, live, i, g.radius, 8);
    const __m512d reach = _mm512_add_pd(_mm512_add_pd(Ri, Rj), tail);
    const __mmask8 hit = _mm512_mask_cmp_pd_mask(live, d2, _mm512_mul_pd(reach, reach), _CMP_LT_OQ);
    // Whole vectors stored, `slack` past the run at most; the count moves on by the hits only.
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(pairs + n),
                        _mm256_maskz_compress_epi32(hit, _mm256_add_epi32(_mm256_set1_epi32(int(k)), iota)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(rows + n), _mm256_maskz_compress_epi32(hit, i));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(images + n), _mm256_cvtepi32_epi8(_mm256_maskz_compress_epi32(hit, s)));
    n += std::size_t(__builtin_popcount(hit));
  }
  return n;
}

}  // namespace

template <int D>
std::size_t gather_avx512(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                          std::uint32_t* pairs, std::uint8_t* images) {
  return gather<D>(g, k_begin, k_end, rows, pairs, images);
}

template std::size_t gather_avx512<2>(const Geometry<2>&, std::uint32_t, std::uint32_t, std::uint32_t*, std::uint32_t*,
                                      std::uint8_t*);
template std::size_t gather_avx512<3>(const Geometry<3>&, std::uint32_t, std::uint32_t, std::uint32_t*, std::uint32_t*,
                                      std::uint8_t*);

}  // namespace grains::pair_filter
