// AVX-512 build of the neighbour build's candidate test (candidate_test.hpp). Compiled for AVX-512
// whatever the build flags and without FMA contraction (engine/CMakeLists.txt), so each lane does the
// portable build's operations.
#include "neighbours/candidate_test.hpp"

#include "interactions/pair_avx512.hpp"

namespace grains::candidate_test {
namespace {

// The width's operations are members.
struct Test8 : pair_avx512::Width8 {
  template <int D>
  GRAINS_AVX512_PAIRS static std::size_t test(const Probe<D>& q, std::uint32_t b, std::uint32_t e, bool wraps, const Finds& out,
                                              std::size_t used) {
    constexpr int images = D == 3 ? 27 : 9;
    const __m256i p = _mm256_set1_epi32(int(q.p));
    const V extra = all(q.reach_extra), rp = all(q.rp);
    for (std::uint32_t s = b; s < e; s += 8) {
      const Mask live = first_lanes(e - s);
      V d2 = zero();
      __m256i img = _mm256_set1_epi32(images / 2);
      if (wraps) {
        img = _mm256_setzero_si256();
        for (int a = D - 1; a >= 0; --a) {
          const V raw = sub(_mm512_maskz_loadu_pd(live, q.x[a] + s), all(q.xp[a]));
          const __mmask8 below = _mm512_cmp_pd_mask(raw, all(-q.half[a]), _CMP_LT_OQ);
          const __mmask8 above = _mm512_cmp_pd_mask(raw, all(q.half[a]), _CMP_GT_OQ);
          const V period = all(q.period[a]);
          const V r = sub(add(raw, _mm512_maskz_mov_pd(below, period)), _mm512_maskz_mov_pd(above, period));
          // img * 3 + 1 + below - above
          const __m256i one = _mm256_set1_epi32(1);
          img = _mm256_add_epi32(_mm256_mullo_epi32(img, _mm256_set1_epi32(3)), one);
          img = _mm256_mask_add_epi32(img, below, img, one);
          img = _mm256_mask_sub_epi32(img, above, img, one);
          d2 = add(d2, mul(r, r));
        }
      } else {
        for (int a = D - 1; a >= 0; --a) {
          const V r = sub(_mm512_maskz_loadu_pd(live, q.x[a] + s), all(q.xp[a]));
          d2 = add(d2, mul(r, r));
        }
      }
      const V cut = add(add(rp, _mm512_maskz_loadu_pd(live, q.radius + s)), extra);
      const __mmask8 hit = _mm512_mask_cmp_pd_mask(live, d2, mul(cut, cut), _CMP_LT_OQ);
      const __m256i m = _mm256_maskz_loadu_epi32(live, q.member + s);
      const __mmask8 reversed = _mm256_cmplt_epu32_mask(m, p);
      const __m256i lo = _mm256_mask_blend_epi32(reversed, p, m), hi = _mm256_mask_blend_epi32(reversed, m, p);
      const __m256i image = _mm256_mask_sub_epi32(img, reversed, _mm256_set1_epi32(images - 1), img);
      // Whole vectors stored, `slack` past the finds at most; the count moves on by the hits only.
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.i + used), _mm256_maskz_compress_epi32(hit, lo));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.j + used), _mm256_maskz_compress_epi32(hit, hi));
      _mm_storel_epi64(reinterpret_cast<__m128i*>(out.image + used), _mm256_cvtepi32_epi8(_mm256_maskz_compress_epi32(hit, image)));
      used += std::size_t(__builtin_popcount(hit));
    }
    return used;
  }
};

}  // namespace

template <int D>
std::size_t test_avx512(const Probe<D>& q, std::uint32_t b, std::uint32_t e, bool wraps, const Finds& out,
                        std::size_t used) {
  return Test8::test<D>(q, b, e, wraps, out, used);
}

template std::size_t test_avx512<2>(const Probe<2>&, std::uint32_t, std::uint32_t, bool, const Finds&, std::size_t);
template std::size_t test_avx512<3>(const Probe<3>&, std::uint32_t, std::uint32_t, bool, const Finds&, std::size_t);

}  // namespace grains::candidate_test
