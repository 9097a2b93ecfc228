// AVX2 build of the pair filter (pair_filter.hpp): four entries at a time, the selected ones moved to the
// front by a byte shuffle looked up from the hit mask. Compiled for AVX2 whatever the build flags and
// without FMA contraction (engine/CMakeLists.txt), so each lane does the portable build's operations.
#include <array>

#include "interactions/pair_avx2.hpp"
#include "interactions/pair_filter.hpp"

namespace grains::pair_filter {
namespace {

// For each mask of four lanes, the byte shuffle that packs the set lanes' 32-bit words to the front.
alignas(16) constexpr std::array<std::array<std::uint8_t, 16>, 16> packing = [] {
  std::array<std::array<std::uint8_t, 16>, 16> table{};
  for (unsigned m = 0; m < 16; ++m) {
    unsigned to = 0;
    for (unsigned l = 0; l < 4; ++l)
      if (m >> l & 1) {
        for (unsigned b = 0; b < 4; ++b) table[m][4 * to + b] = std::uint8_t(4 * l + b);
        ++to;
      }
    for (unsigned b = 4 * to; b < 16; ++b) table[m][b] = 0x80;   // zero
  }
  return table;
}();

// The width's operations are members; its loads are pair_avx2's.
struct Filter4 : pair_avx2::Width4 {
  template <int D, bool Selection>
  GRAINS_AVX2_PAIRS static std::size_t select(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                                              std::uint32_t* pairs, std::uint8_t* images) {
    using namespace pair_avx2;
    using pair_avx2::gather;   // not the pair filter's own gather
    const double* x = g.position[0].data();
    const double* shift = g.shift[0].data();
    const V tail = all(g.tail_reach);
    const __m128i iota = _mm_setr_epi32(0, 1, 2, 3), dim = _mm_set1_epi32(D);
    const __m128i low_bytes = _mm_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1);
    std::size_t n = 0;
    for (std::uint32_t k = k_begin; k < k_end; k += 4) {
      const std::size_t left = k_end - k;
      const __m128i lanes = first_lanes(left);
      const V live = widen(lanes);
      const __m128i j = load_index(g.partner + k, lanes), i = load_index(g.owner + k, lanes);
      const __m128i s = load_bytes(g.image + k, left);
      const Lanes4 jx(_mm_mullo_epi32(j, dim)), ix(_mm_mullo_epi32(i, dim)), sx(_mm_mullo_epi32(s, dim));
      V d2 = zero();
      for (int a = 0; a < D; ++a) {
        const V r = sub(add(gather(x + a, jx), gather(shift + a, sx)), gather(x + a, ix));
        d2 = a == 0 ? mul(r, r) : add(d2, mul(r, r));   // (x^2 + y^2) + z^2, as Eigen
      }
      const V reach = add(add(gather(g.radius, Lanes4(i)), gather(g.radius, Lanes4(j))), tail);
      const unsigned hit = bits(both(live, less(d2, mul(reach, reach))));
      const __m128i entry = Selection ? load_index(g.entry + k, lanes) : _mm_add_epi32(_mm_set1_epi32(int(k)), iota);
      // Whole vectors stored, `slack` past the run at most; the count moves on by the hits only.
      const __m128i pack = _mm_load_si128(reinterpret_cast<const __m128i*>(packing[hit].data()));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(pairs + n), _mm_shuffle_epi8(entry, pack));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(rows + n), _mm_shuffle_epi8(i, pack));
      const int packed_images = _mm_cvtsi128_si32(_mm_shuffle_epi8(_mm_shuffle_epi8(s, pack), low_bytes));
      std::memcpy(images + n, &packed_images, 4);
      n += std::size_t(__builtin_popcount(hit));
    }
    return n;
  }
};

}  // namespace

template <int D>
std::size_t gather_avx2(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                        std::uint32_t* pairs, std::uint8_t* images) {
  return g.entry ? Filter4::select<D, true>(g, k_begin, k_end, rows, pairs, images)
                 : Filter4::select<D, false>(g, k_begin, k_end, rows, pairs, images);
}

template std::size_t gather_avx2<2>(const Geometry<2>&, std::uint32_t, std::uint32_t, std::uint32_t*, std::uint32_t*,
                                    std::uint8_t*);
template std::size_t gather_avx2<3>(const Geometry<3>&, std::uint32_t, std::uint32_t, std::uint32_t*, std::uint32_t*,
                                    std::uint8_t*);

}  // namespace grains::pair_filter
