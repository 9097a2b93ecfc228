// AVX-512 build of the pair filter (pair_filter.hpp). Compiled for AVX-512 whatever the build flags and
// without FMA contraction (engine/CMakeLists.txt), so each lane does the portable build's operations.
#include "interactions/pair_filter.hpp"

#include "interactions/pair_avx512.hpp"

namespace grains::pair_filter {

static_assert(sizeof(Vec<2>) == 2 * sizeof(double) && sizeof(Vec<3>) == 3 * sizeof(double), "positions are packed");

namespace {

// The width's operations (gather too: not the pair filter's own) are members.
struct Filter8 : pair_avx512::Width8 {
  // Loads: a full vector's positions read by load_2d (and the z components gathered), not gathered
  // (pair_filter::vector_loads).
  template <int D, bool Selection, bool Loads>
  GRAINS_AVX512_PAIRS static std::size_t select(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                                                std::uint32_t* pairs, std::uint8_t* images) {
    using namespace pair_avx512;
    const double* x = g.position[0].data();
    const V tail = all(g.tail_reach);
    const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const ImageShifts<D> shifts(g.shift);
    std::size_t n = 0;
    for (std::uint32_t k = k_begin; k < k_end; k += 8) {
      const Mask live = first_lanes(k_end - k);
      const __m256i j = _mm256_maskz_loadu_epi32(live, g.partner + k);
      const __m256i i = _mm256_maskz_loadu_epi32(live, g.owner + k);
      const __m256i s = _mm256_cvtepu8_epi32(_mm_maskz_loadu_epi8(live, g.image + k));
      const __m256i jx = times_dim<D>(j), ix = times_dim<D>(i);
      V shift[D];
      shifts.lookup(s, shift);
      V xj[D], xi[D];
      if (Loads && live == 0xFF) {
        load_2d<D>(x, g.partner + k, xj[0], xj[1]), load_2d<D>(x, g.owner + k, xi[0], xi[1]);
        if constexpr (D == 3) xj[2] = gather(x + 2, jx, live), xi[2] = gather(x + 2, ix, live);
      } else {
        for (int a = 0; a < D; ++a) xj[a] = gather(x + a, jx, live), xi[a] = gather(x + a, ix, live);
      }
      V d2 = zero();
      for (int a = 0; a < D; ++a) {
        const V r = sub(add(xj[a], shift[a]), xi[a]);
        d2 = a == 0 ? mul(r, r) : add(d2, mul(r, r));   // (x^2 + y^2) + z^2, as Eigen
      }
      const V reach = add(add(gather(g.radius, i, live), gather(g.radius, j, live)), tail);
      const Mask hit = both(live, less(d2, mul(reach, reach)));
      const __m256i entry =
          Selection ? _mm256_maskz_loadu_epi32(live, g.entry + k) : _mm256_add_epi32(_mm256_set1_epi32(int(k)), iota);
      // Whole vectors stored, `slack` past the run at most; the count moves on by the hits only.
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(pairs + n), _mm256_maskz_compress_epi32(hit, entry));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(rows + n), _mm256_maskz_compress_epi32(hit, i));
      _mm_storel_epi64(reinterpret_cast<__m128i*>(images + n), _mm256_cvtepi32_epi8(_mm256_maskz_compress_epi32(hit, s)));
      n += std::size_t(__builtin_popcount(hit));
    }
    return n;
  }
};

}  // namespace

template <int D>
std::size_t gather_avx512(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                          std::uint32_t* pairs, std::uint8_t* images) {
  if (vector_loads())
    return g.entry ? Filter8::select<D, true, true>(g, k_begin, k_end, rows, pairs, images)
                   : Filter8::select<D, false, true>(g, k_begin, k_end, rows, pairs, images);
  return g.entry ? Filter8::select<D, true, false>(g, k_begin, k_end, rows, pairs, images)
                 : Filter8::select<D, false, false>(g, k_begin, k_end, rows, pairs, images);
}

template std::size_t gather_avx512<2>(const Geometry<2>&, std::uint32_t, std::uint32_t, std::uint32_t*, std::uint32_t*,
                                      std::uint8_t*);
template std::size_t gather_avx512<3>(const Geometry<3>&, std::uint32_t, std::uint32_t, std::uint32_t*, std::uint32_t*,
                                      std::uint8_t*);

}  // namespace grains::pair_filter
