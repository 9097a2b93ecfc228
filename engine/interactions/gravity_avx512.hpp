// AVX-512 pieces shared by the direct and tree gravity kernels. They are compiled for AVX-512 whatever the
// build flags (the binary stays portable x86-64): call them only from GRAINS_AVX512 functions, and those only
// after gravity_direct::supported(Isa::avx512).
#pragma once
#include <immintrin.h>

#define GRAINS_AVX512 __attribute__((target("avx512f,avx2,fma")))

namespace grains::gravity_avx512 {

// 1 / sqrt(r2). A zmm square root and division take about as long as two ymm ones, so on eight lanes the
// divider, not the FMA units, would set the pace; instead the 14-bit estimate (vrsqrt14pd) is refined by two
// Newton steps y <- y + y (1 - r2 y^2) / 2 in FP64 (relative error 2^-14 -> ~6e-9 -> round-off). Measured
// over r2 = 1e-100 .. 1e100: within a few units in the last place (the correctly rounded square root and
// division give about half that), so not bit for bit the AVX2 and portable kernels' values.
// r2 = 0 gives NaN, not infinity: mask such lanes.
GRAINS_AVX512 inline __m512d rsqrt(__m512d r2) {
  const __m512d one = _mm512_set1_pd(1.0), half = _mm512_set1_pd(0.5);
  __m512d y = _mm512_rsqrt14_pd(r2);
  for (int k = 0; k < 2; ++k) {
    const __m512d e = _mm512_fnmadd_pd(_mm512_mul_pd(r2, y), y, one);   // 1 - r2 y^2
    y = _mm512_fmadd_pd(_mm512_mul_pd(half, y), e, y);
  }
  return y;
}

// 1 / r2^{3/2} = y^3 (within about 4 units in the last place).
GRAINS_AVX512 inline __m512d inverse_cube(__m512d r2) {
  const __m512d y = rsqrt(r2);
  return _mm512_mul_pd(_mm512_mul_pd(y, y), y);
}

// Lane sum in a fixed order: the halves added lane by lane, then (0+2, 1+3), then the two.
GRAINS_AVX512 inline double lane_sum(__m512d v) {
  const __m256d quad = _mm256_add_pd(_mm512_castpd512_pd256(v), _mm512_extractf64x4_pd(v, 1));   // (0+4, .., 3+7)
  const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(quad), _mm256_extractf128_pd(quad, 1));
  return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}

}  // namespace grains::gravity_avx512
