// AVX2 pieces of the pair loop's kernels (pair_filter_avx2.cpp; cohesive_contacts_kernel.hpp and
// linear_contacts_kernel.hpp at four lanes): four doubles per vector, one lane per gathered pair, for
// processors without AVX-512 (pair_avx512.hpp is the eight-lane build). AVX2 has gathers but no mask
// registers, scatters or compression: a mask is a vector of all-ones or all-zero lanes, and its bits
// (movemask) decide the rare branches. Compiled for AVX2 whatever the build flags (the binary stays portable
// x86-64): call these only from GRAINS_AVX2_PAIRS functions, and those only where pair_filter::isa() is
// Isa::avx2. Include this header only in files compiled without multiply-add contraction
// (engine/CMakeLists.txt); the target has no FMA either.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>

#include <immintrin.h>

#include "core/vec.hpp"

#define GRAINS_AVX2_PAIRS __attribute__((target("avx2,popcnt")))

namespace grains::pair_avx2 {

template <int D, bool Dense>
struct Contacts4;
template <int D>
struct ImageShifts;

// The operations of the kernels written once for both widths (cohesive_contacts_kernel.hpp,
// linear_contacts_kernel.hpp), at four lanes; pair_avx512.hpp's Width8 has the same ones at eight. A mask is
// a vector of all-ones or all-zero lanes; blend(m, a, op(...)) computes op on every lane.
struct Width4 {
  static constexpr int lanes = 4;
  using V = __m256d;
  using Mask = __m256d;
  template <int D, bool Dense = false, bool /*Loads: the AVX-512 build's*/ = false>
  using Contacts = Contacts4<D, Dense>;
  template <int D>
  using Shifts = ImageShifts<D>;

  GRAINS_AVX2_PAIRS static V add(V a, V b) { return _mm256_add_pd(a, b); }
  GRAINS_AVX2_PAIRS static V sub(V a, V b) { return _mm256_sub_pd(a, b); }
  GRAINS_AVX2_PAIRS static V mul(V a, V b) { return _mm256_mul_pd(a, b); }
  GRAINS_AVX2_PAIRS static V div(V a, V b) { return _mm256_div_pd(a, b); }
  GRAINS_AVX2_PAIRS static V sqrt(V a) { return _mm256_sqrt_pd(a); }
  GRAINS_AVX2_PAIRS static V min(V a, V b) { return _mm256_min_pd(a, b); }
  GRAINS_AVX2_PAIRS static V max(V a, V b) { return _mm256_max_pd(a, b); }
  GRAINS_AVX2_PAIRS static V all(double a) { return _mm256_set1_pd(a); }
  GRAINS_AVX2_PAIRS static V zero() { return _mm256_setzero_pd(); }
  // |a|, -a and std::copysign(magnitude, sign): sign-bit operations, exactly as the scalar ones.
  GRAINS_AVX2_PAIRS static V abs(V a) { return _mm256_andnot_pd(sign_bit(), a); }
  GRAINS_AVX2_PAIRS static V neg(V a) { return _mm256_xor_pd(a, sign_bit()); }
  GRAINS_AVX2_PAIRS static V copysign(V magnitude, V sign) {
    return _mm256_or_pd(_mm256_andnot_pd(sign_bit(), magnitude), _mm256_and_pd(sign, sign_bit()));
  }

  // Masks. blend(m, a, b) takes b where m is set; bits(m) has bit l set for lane l.
  GRAINS_AVX2_PAIRS static V blend(Mask m, V a, V b) { return _mm256_blendv_pd(a, b, m); }
  GRAINS_AVX2_PAIRS static Mask less(V a, V b) { return _mm256_cmp_pd(a, b, _CMP_LT_OQ); }
  GRAINS_AVX2_PAIRS static Mask less_equal(V a, V b) { return _mm256_cmp_pd(a, b, _CMP_LE_OQ); }
  GRAINS_AVX2_PAIRS static Mask greater(V a, V b) { return _mm256_cmp_pd(a, b, _CMP_GT_OQ); }
  GRAINS_AVX2_PAIRS static Mask both(Mask m, Mask n) { return _mm256_and_pd(m, n); }
  GRAINS_AVX2_PAIRS static Mask either(Mask m, Mask n) { return _mm256_or_pd(m, n); }
  GRAINS_AVX2_PAIRS static Mask but_not(Mask m, Mask n) { return _mm256_andnot_pd(n, m); }
  GRAINS_AVX2_PAIRS static unsigned bits(Mask m) { return unsigned(_mm256_movemask_pd(m)); }
  GRAINS_AVX2_PAIRS static bool any(Mask m) { return bits(m) != 0; }
  GRAINS_AVX2_PAIRS static int count(Mask m) { return __builtin_popcount(bits(m)); }

 private:
  GRAINS_AVX2_PAIRS static V sign_bit() { return _mm256_set1_pd(-0.0); }
};

using V = Width4::V;

// The four 32-bit lanes of an index mask widened to a mask of doubles, and back.
GRAINS_AVX2_PAIRS inline V widen(__m128i m) { return _mm256_castsi256_pd(_mm256_cvtepi32_epi64(m)); }
GRAINS_AVX2_PAIRS inline __m128i narrow(V m) {
  return _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(_mm256_castpd_si256(m), _mm256_setr_epi32(0, 2, 4, 6, 0, 0, 0, 0)));
}
GRAINS_AVX2_PAIRS inline unsigned bits(__m128i m) { return unsigned(_mm_movemask_ps(_mm_castsi128_ps(m))); }

// The mask of the first `left` lanes (all four from left = 4 on), as indices.
GRAINS_AVX2_PAIRS inline __m128i first_lanes(std::size_t left) {
  const __m128i iota = _mm_setr_epi32(0, 1, 2, 3);
  return _mm_cmplt_epi32(iota, _mm_set1_epi32(int(left < 4 ? left : 4)));
}

// The lanes' indices as plain integers, for the loads below.
struct Lanes4 {
  alignas(16) std::uint32_t at[4];
  GRAINS_AVX2_PAIRS explicit Lanes4(__m128i v) { _mm_store_si128(reinterpret_cast<__m128i*>(at), v); }
  // a[0 .. left) (at most four), read as integers: a vector's store would delay the loads that use them.
  // A dead lane repeats lane 0, so that what it reads (its results are never stored) is the batch's own:
  // an entry of another thread's rows might be being written.
  Lanes4(const std::uint32_t* a, std::size_t left) {
    if (left >= 4) {
      std::memcpy(at, a, sizeof at);
    } else {
      for (std::size_t l = 0; l < 4; ++l) at[l] = l < left ? a[l] : a[0];
    }
  }
};
// The lanes' a[idx]: four loads. On processors with AVX2 but not AVX-512 (AMD's before Zen 4) a gather
// instruction is slower than the loads it stands for.
GRAINS_AVX2_PAIRS inline V gather(const double* a, const Lanes4& idx) {
  return _mm256_setr_pd(a[idx.at[0]], a[idx.at[1]], a[idx.at[2]], a[idx.at[3]]);
}
// The lanes' pairs (a[2 idx], a[2 idx + 1]) (2D positions and velocities) as the vectors of their first
// and second components: four 16-byte loads, transposed.
GRAINS_AVX2_PAIRS inline void gather_pairs(const double* a, const Lanes4& idx, V& first, V& second) {
  const __m128d p0 = _mm_loadu_pd(a + 2 * std::size_t(idx.at[0])), p1 = _mm_loadu_pd(a + 2 * std::size_t(idx.at[1]));
  const __m128d p2 = _mm_loadu_pd(a + 2 * std::size_t(idx.at[2])), p3 = _mm_loadu_pd(a + 2 * std::size_t(idx.at[3]));
  const V even = _mm256_insertf128_pd(_mm256_castpd128_pd256(p0), p2, 1);   // (x0, y0, x2, y2)
  const V odd = _mm256_insertf128_pd(_mm256_castpd128_pd256(p1), p3, 1);    // (x1, y1, x3, y3)
  first = _mm256_unpacklo_pd(even, odd), second = _mm256_unpackhi_pd(even, odd);
}
// a[0..3] on the lanes of m (the others read nothing and hold zero); m is all four lanes unless `left` is
// below four.
GRAINS_AVX2_PAIRS inline __m128i load_index(const std::uint32_t* a, __m128i m, std::size_t left = 0) {
  if (left >= 4) return _mm_loadu_si128(reinterpret_cast<const __m128i*>(a));
  return _mm_maskload_epi32(reinterpret_cast<const int*>(a), m);
}
// The first `left` (at most four) bytes of a, widened to 32-bit lanes; the rest zero. Reads no further.
// The word is built in a register: a copy of a variable length goes through memory byte by byte, and
// reading it back as one word waits for those stores to complete (9 % of the bench disks' run on Zen 3).
GRAINS_AVX2_PAIRS inline __m128i load_bytes(const std::uint8_t* a, std::size_t left) {
  std::uint32_t word = 0;
  if (left >= 4) std::memcpy(&word, a, 4);
  else
    for (std::size_t l = 0; l < left; ++l) word |= std::uint32_t(a[l]) << (8 * l);
  return _mm_cvtepu8_epi32(_mm_cvtsi32_si128(int(word)));
}

// Of the touching lanes (list entries k), those that touched at the last evaluation too (stamp + 1 ==
// evaluation; the contact's first step otherwise), restamped with this evaluation. Dense: the lanes' k are
// consecutive, from k0 (the shell's slots): loads and stores; else read and stored lane by lane.
template <bool Dense>
GRAINS_AVX2_PAIRS inline __m128i steady_contacts(__m128i touching, const Lanes4& k, std::uint32_t k0, std::size_t left,
                                                 std::uint32_t* touched, std::uint32_t evaluation) {
  const __m128i now = _mm_set1_epi32(int(evaluation));
  const __m128i stamp = Dense ? load_index(touched + k0, touching, left)
                              : _mm_setr_epi32(int(touched[k.at[0]]), int(touched[k.at[1]]), int(touched[k.at[2]]),
                                               int(touched[k.at[3]]));
  const __m128i steady = _mm_and_si128(touching, _mm_cmpeq_epi32(_mm_add_epi32(stamp, _mm_set1_epi32(1)), now));
  if constexpr (Dense) {   // a whole batch: the old stamps blended in and stored (see set_per_entry)
    if (left >= 4) _mm_storeu_si128(reinterpret_cast<__m128i*>(touched + k0), _mm_blendv_epi8(stamp, now, steady));
    else _mm_maskstore_epi32(reinterpret_cast<int*>(touched + k0), steady, now);
  } else {
    for (unsigned m = bits(steady); m; m &= m - 1) touched[k.at[__builtin_ctz(m)]] = evaluation;
  }
  return steady;
}

// The lanes' indices times `scale` (the D-vectors of the particle arrays).
inline Lanes4 times(const Lanes4& idx, std::uint32_t scale) {
  Lanes4 out = idx;
  for (std::uint32_t& v : out.at) v *= scale;
  return out;
}

// The periodic image shifts of the neighbour list, gathered component by component (shift[s][a] at
// s D + a).
template <int D>
struct ImageShifts {
  const double* first;   // shift[0][0]
  explicit ImageShifts(const Vec<D>* shift) : first(shift[0].data()) {}
};

// The geometry of four gathered pairs q .. q + 3 (the first `left` of them live), as pair_avx512::Contacts8
// (the same operations in the same order): r = (x_j + shift) - x_i, d2 = (r_x^2 + r_y^2) + r_z^2,
// touching when d2 < (R_i + R_j)^2, and which touched at the last evaluation too (restamped). The lanes'
// rows i, partners j and entries k are kept as integers, for the kernels' loads; Dense as in per_entry (2D
// only). Its methods are Contacts8's, for four lanes filling half of a block of eight.
template <int D, bool Dense = false>
struct Contacts4 {
  using Mask = Width4::Mask;
  Lanes4 il, kl, jl, iD, jD;   // iD, jD: i D and j D (3D only)
  std::uint32_t k0;
  bool full;   // all four lanes live
  unsigned half;   // 0 or 4: the block's first or second half
  Mask live;
  V r[D], d2, Ri, Rj, Rsum;
  Mask touching, steady;
  [[gnu::always_inline]] GRAINS_AVX2_PAIRS Contacts4(const std::uint32_t* rows, const std::uint32_t* pairs,
                                                     const std::uint8_t* images, std::size_t q, std::size_t left,
                                                     const std::uint32_t* partner, const ImageShifts<D>& shifts,
                                                     const double* position, const double* radius, std::uint32_t* touched,
                                                     std::uint32_t evaluation, const double* const* slot_radius = nullptr)
      : il(rows + q, left), kl(pairs + q, left), jl(kl), iD(il), jD(kl), k0(pairs[q]), full(left >= 4), half(q & 7) {
    static_assert(D == 2 || !Dense);
    using W = Width4;
    if constexpr (Dense) jl = Lanes4(partner + k0, left);
    else
      for (int l = 0; l < 4; ++l) jl.at[l] = partner[kl.at[l]];   // a dead lane's k is lane 0's
    live = widen(first_lanes(left));
    const Lanes4 sl(_mm_mullo_epi32(load_bytes(images + q, left), _mm_set1_epi32(D)));   // the shifts' first components
    const double* s = shifts.first;
    if constexpr (D == 2) {
      V xi, yi, xj, yj;
      gather_pairs(position, il, xi, yi), gather_pairs(position, jl, xj, yj);
      r[0] = W::sub(W::add(xj, gather(s, sl)), xi);
      r[1] = W::sub(W::add(yj, gather(s + 1, sl)), yi);
    } else {
      iD = times(il, D), jD = times(jl, D);
      for (int a = 0; a < D; ++a) r[a] = W::sub(W::add(gather(position + a, jD), gather(s + a, sl)), gather(position + a, iD));
    }
    for (int a = 0; a < D; ++a) d2 = a == 0 ? W::mul(r[a], r[a]) : W::add(d2, W::mul(r[a], r[a]));
    if constexpr (Dense) Ri = per_entry(slot_radius[0]), Rj = per_entry(slot_radius[1]);
    else Ri = gather(radius, il), Rj = gather(radius, jl);
    Rsum = W::add(Ri, Rj);
    touching = W::both(live, W::less(d2, W::mul(Rsum, Rsum)));
    steady = widen(steady_contacts<Dense>(narrow(touching), kl, k0, left, touched, evaluation));
  }

  // Particle data: the lanes' a[i] or a[j], their D-vectors a[D i + 0 .. D - 1] (a 2D one as one 16-byte
  // load). Every lane reads (a dead lane lane 0's): m is the AVX-512 build's.
  GRAINS_AVX2_PAIRS V at_i(const double* a, Mask /*m*/) const { return gather(a, il); }
  GRAINS_AVX2_PAIRS V at_j(const double* a, Mask /*m*/) const { return gather(a, jl); }
  GRAINS_AVX2_PAIRS void vector_at_i(const double* a, V out[D]) const { vector_at(a, il, iD, out); }
  GRAINS_AVX2_PAIRS void vector_at_j(const double* a, V out[D]) const { vector_at(a, jl, jD, out); }

  // Per-entry data, a[k]: gathered, or loaded from a + k0 where the lanes' k are consecutive (all four
  // lanes where `full`, else the live ones).
  GRAINS_AVX2_PAIRS V per_entry(const double* a) const {
    if constexpr (Dense) return full ? _mm256_loadu_pd(a + k0) : _mm256_maskload_pd(a + k0, _mm256_castpd_si256(live));
    else return gather(a, kl);
  }
  // a[k] = v on the lanes of m: stored to a + k0, or lane by lane. A whole batch (`full`, its entries the
  // batch's own) stores `old` (what per_entry read) on the other lanes with a plain store: AMD's Zen cores
  // run a masked store as a long microcoded sequence.
  GRAINS_AVX2_PAIRS void set_per_entry(double* a, Mask m, V v, V old) const {
    if constexpr (Dense) {
      if (full) _mm256_storeu_pd(a + k0, Width4::blend(m, old, v));
      else _mm256_maskstore_pd(a + k0, _mm256_castpd_si256(m), v);
    } else {
      alignas(32) double value[4];
      _mm256_store_pd(value, v);
      for (unsigned b = Width4::bits(m); b; b &= b - 1) a[kl.at[__builtin_ctz(b)]] = value[__builtin_ctz(b)];
    }
  }
  // The 3-vectors a[3 k + 0 .. 2] (the springs of spheres), and their stores on the lanes of m.
  GRAINS_AVX2_PAIRS void vector_per_entry(const double* a, V out[3]) const {
    static_assert(!Dense);
    const Lanes4 k3 = times(kl, 3);
    for (int c = 0; c < 3; ++c) out[c] = gather(a + c, k3);
  }
  GRAINS_AVX2_PAIRS void set_vector_per_entry(double* a, Mask m, const V v[3]) const {
    const Lanes4 k3 = times(kl, 3);
    alignas(32) double value[3][4];
    for (int c = 0; c < 3; ++c) _mm256_store_pd(value[c], v[c]);
    for (unsigned lanes = Width4::bits(m); lanes; lanes &= lanes - 1) {
      const unsigned l = unsigned(__builtin_ctz(lanes));
      for (int c = 0; c < 3; ++c) a[k3.at[l] + c] = value[c][l];
    }
  }
  // a[k] = value on the lanes of m, one by one.
  GRAINS_AVX2_PAIRS void set_entries(std::uint32_t* a, Mask m, std::uint32_t value) const {
    for (unsigned l = Width4::bits(m); l; l &= l - 1) a[Dense ? k0 + __builtin_ctz(l) : kl.at[__builtin_ctz(l)]] = value;
  }

  // The batch's results, into its half of a block of eight (Results8), with plain stores: store(block, m, v)
  // stores the other lanes too (they are never read). A block's masks get the lanes' bits in their half,
  // the first half's clearing the second's.
  GRAINS_AVX2_PAIRS void store(double* block, V v) const { _mm256_store_pd(block + half, v); }
  GRAINS_AVX2_PAIRS void store(double* block, Mask /*m*/, V v) const { _mm256_store_pd(block + half, v); }
  void store_partners(std::uint32_t* block) const { std::memcpy(block + half, jl.at, sizeof jl.at); }
  GRAINS_AVX2_PAIRS void set_bits(std::uint8_t& block_mask, Mask m) const {
    const unsigned b = Width4::bits(m);
    block_mask = std::uint8_t(half ? (block_mask & 0x0F) | b << 4 : b);
  }

 private:
  GRAINS_AVX2_PAIRS static void vector_at(const double* a, const Lanes4& idx, const Lanes4& idxD, V out[D]) {
    if constexpr (D == 2) gather_pairs(a, idx, out[0], out[1]);
    else
      for (int c = 0; c < D; ++c) out[c] = gather(a + c, idxD);
  }
};

}  // namespace grains::pair_avx2
