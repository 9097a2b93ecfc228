// The 3D first-half passes (drift_3, half_kick_spin_3) written for AVX-512. The compilers vectorise
// drift_body across particles, pulling every array's x, y and z apart with permutes and back again; but
// each operation but one is per component, so here the arrays are read as they lie, eight components a
// vector (eight particles in three vectors), and only the per-particle factor (1/m, 1/I) and the squared
// move are permuted. drift_body's operations lane by lane (no FMA), so every array written is bit for bit
// drift_body's; the witness sums run in another order (only their finiteness matters).
#include <algorithm>
#include <immintrin.h>

#include "core/integrator.hpp"

#define GRAINS_AVX512_PASS __attribute__((target("avx512f")))

// GCC 12's avx512fintrin.h fills "undefined" vectors by self-initialisation, which -Wuninitialized flags.
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace grains::integrator_detail {
namespace {

using V = __m512d;

// The pending kick of step hk and drag factor keep, for the compiled loops that finish a pass.
PendingKick kick_of(double hk, double keep) {
  PendingKick kick;
  kick.active = true, kick.h = hk, kick.keep = keep;
  return kick;
}

// Component k of the 24 in three vectors belongs to particle k / 3: the factor of eight particles spread
// over their components, vector j holding components 8j .. 8j + 7.
GRAINS_AVX512_PASS inline void spread(V per_particle, V out[3]) {
  out[0] = _mm512_permutexvar_pd(_mm512_setr_epi64(0, 0, 0, 1, 1, 1, 2, 2), per_particle);
  out[1] = _mm512_permutexvar_pd(_mm512_setr_epi64(2, 3, 3, 3, 4, 4, 4, 5), per_particle);
  out[2] = _mm512_permutexvar_pd(_mm512_setr_epi64(5, 5, 6, 6, 6, 7, 7, 7), per_particle);
}

// A per-axis constant c[0..2] laid out as the components are: vector j lane l holds c[(8j + l) % 3].
GRAINS_AVX512_PASS inline void per_axis(const double* c, V out[3]) {
  for (int j = 0; j < 3; ++j) {
    alignas(64) double lanes[8];
    for (int l = 0; l < 8; ++l) lanes[l] = c[(8 * j + l) % 3];
    out[j] = _mm512_load_pd(lanes);
  }
}

// The eight particles' x^2 + y^2 + z^2, added in that order, from their squared components in three vectors.
GRAINS_AVX512_PASS inline V particle_sums(const V s[3]) {
  const V x = _mm512_permutex2var_pd(_mm512_permutex2var_pd(s[0], _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0), s[1]),
                                     _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 10, 13), s[2]);
  const V y = _mm512_permutex2var_pd(_mm512_permutex2var_pd(s[0], _mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0), s[1]),
                                     _mm512_setr_epi64(0, 1, 2, 3, 4, 8, 11, 14), s[2]);
  const V z = _mm512_permutex2var_pd(_mm512_permutex2var_pd(s[0], _mm512_setr_epi64(2, 5, 8, 11, 14, 0, 0, 0), s[1]),
                                     _mm512_setr_epi64(0, 1, 2, 3, 4, 9, 12, 15), s[2]);
  return _mm512_add_pd(_mm512_add_pd(x, y), z);
}

template <int Measure, bool Follow, bool Kick>
GRAINS_AVX512_PASS DriftSums drift_3_body(std::size_t n, double h, const double* __restrict inverse_mass,
                                          double* __restrict x, double* __restrict v, double* __restrict vp,
                                          const double* __restrict f, double* __restrict f_prev, const DriftGeometry& g,
                                          double hk, double keep) {
  const V half_h = _mm512_set1_pd(0.5 * h), step = _mm512_set1_pd(h), half_hk = _mm512_set1_pd(0.5 * hk);
  const V kept = _mm512_set1_pd(keep), newer = _mm512_set1_pd(1.75), older = _mm512_set1_pd(0.75);
  V lower[3], scale[3], reference_lower[3], strain[3];
  per_axis(g.lower, lower), per_axis(g.scale, scale), per_axis(g.reference_lower, reference_lower), per_axis(g.strain, strain);
  V witness = _mm512_setzero_pd(), kicked = _mm512_setzero_pd(), largest = _mm512_setzero_pd();
  const std::size_t blocks = n / 8;
  for (std::size_t b = 0; b < blocks; ++b) {
    V mass[3], squared[3];
    spread(_mm512_loadu_pd(inverse_mass + 8 * b), mass);
    for (int j = 0; j < 3; ++j) {
      const std::size_t k = 24 * b + 8 * j;
      const V a = _mm512_mul_pd(mass[j], _mm512_loadu_pd(f + k)), a_prev = _mm512_mul_pd(mass[j], _mm512_loadu_pd(f_prev + k));
      V u = _mm512_loadu_pd(v + k);
      if constexpr (Kick) {
        u = _mm512_mul_pd(_mm512_add_pd(u, _mm512_mul_pd(half_hk, a)), kept);   // second_half
        kicked = _mm512_add_pd(kicked, u);
      }
      u = _mm512_add_pd(u, _mm512_mul_pd(half_h, a));
      V r = _mm512_add_pd(_mm512_loadu_pd(x + k), _mm512_mul_pd(step, u));
      const V predicted = _mm512_add_pd(u, _mm512_mul_pd(half_h, _mm512_sub_pd(_mm512_mul_pd(newer, a), _mm512_mul_pd(older, a_prev))));
      _mm512_storeu_pd(f_prev + k, _mm512_setzero_pd());
      witness = _mm512_add_pd(witness, r);
      if constexpr (Follow) r = _mm512_add_pd(lower[j], _mm512_mul_pd(_mm512_sub_pd(r, lower[j]), scale[j]));
      _mm512_storeu_pd(x + k, r), _mm512_storeu_pd(v + k, u), _mm512_storeu_pd(vp + k, predicted);
      if constexpr (Measure > 0) {
        V ref = _mm512_loadu_pd(g.reference + k);
        if constexpr (Measure == 2)
          ref = _mm512_add_pd(reference_lower[j], _mm512_mul_pd(_mm512_sub_pd(ref, reference_lower[j]), strain[j]));
        const V dx = _mm512_sub_pd(r, ref);
        squared[j] = _mm512_mul_pd(dx, dx);
      }
    }
    if constexpr (Measure > 0) largest = _mm512_max_pd(particle_sums(squared), largest);   // as std::max
  }
  DriftSums sums{_mm512_reduce_add_pd(witness), _mm512_reduce_max_pd(largest), _mm512_reduce_add_pd(kicked)};
  if (const std::size_t done = 8 * blocks; done < n) {   // the last few particles as drift_body does them
    DriftGeometry rest = g;
    if (rest.reference) rest.reference += 3 * done;
    const PendingKick pending = kick_of(hk, keep);
    const DriftSums tail = drift_3_compiled(n - done, h, inverse_mass + done, x + 3 * done, v + 3 * done, vp + 3 * done,
                                            f + 3 * done, f_prev + 3 * done, rest, Kick ? &pending : nullptr);
    sums.witness += tail.witness, sums.kick_witness += tail.kick_witness;
    sums.largest_move = std::max(sums.largest_move, tail.largest_move);
  }
  return sums;
}

template <bool Follow, bool Kick>
DriftSums drift_3_measured(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                           double* f_prev, const DriftGeometry& g, double hk, double keep) {
  if (!g.reference) return drift_3_body<0, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  if (g.carried) return drift_3_body<2, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  return drift_3_body<1, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
}
template <bool Kick>
DriftSums drift_3_any(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                      double* f_prev, const DriftGeometry& g, double hk, double keep) {
  return g.follow ? drift_3_measured<true, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep)
                  : drift_3_measured<false, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
}

// half_kick_spin_body's operations on the spins as they lie.
template <bool Kick>
GRAINS_AVX512_PASS double half_kick_spin_3_body(std::size_t n, double h, const double* __restrict inverse_inertia,
                                                double* __restrict torque, double* __restrict w, double hk, double keep) {
  const V half_h = _mm512_set1_pd(0.5 * h), half_hk = _mm512_set1_pd(0.5 * hk), kept = _mm512_set1_pd(keep);
  V kicked = _mm512_setzero_pd();
  const std::size_t blocks = n / 8;
  for (std::size_t b = 0; b < blocks; ++b) {
    V inertia[3];
    spread(_mm512_loadu_pd(inverse_inertia + 8 * b), inertia);
    for (int j = 0; j < 3; ++j) {
      const std::size_t k = 24 * b + 8 * j;
      const V alpha = _mm512_mul_pd(inertia[j], _mm512_loadu_pd(torque + k));
      V u = _mm512_loadu_pd(w + k);
      if constexpr (Kick) {
        u = _mm512_mul_pd(_mm512_add_pd(u, _mm512_mul_pd(half_hk, alpha)), kept);   // second_half
        kicked = _mm512_add_pd(kicked, u);
      }
      _mm512_storeu_pd(w + k, _mm512_add_pd(u, _mm512_mul_pd(half_h, alpha)));
      _mm512_storeu_pd(torque + k, _mm512_setzero_pd());
    }
  }
  double sum = _mm512_reduce_add_pd(kicked);
  if (const std::size_t done = 8 * blocks; done < n) {
    const PendingKick pending = kick_of(hk, keep);
    sum += half_kick_spin_3_compiled(n - done, h, inverse_inertia + done, torque + 3 * done, w + 3 * done,
                                     Kick ? &pending : nullptr);
  }
  return sum;
}

}  // namespace

bool first_half_avx512() {
  static const bool yes = __builtin_cpu_supports("avx512f");
  return yes;
}

DriftSums drift_3_avx512(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                         double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  return kick ? drift_3_any<true>(n, h, m, x, v, vp, f, f_prev, geometry, kick->h, kick->keep)
              : drift_3_any<false>(n, h, m, x, v, vp, f, f_prev, geometry, 0, 1);
}

double half_kick_spin_3_avx512(std::size_t n, double h, const double* inverse_inertia, double* torque, double* w,
                               const PendingKick* kick) {
  return kick ? half_kick_spin_3_body<true>(n, h, inverse_inertia, torque, w, kick->h, kick->keep)
              : half_kick_spin_3_body<false>(n, h, inverse_inertia, torque, w, 0, 1);
}

}  // namespace grains::integrator_detail
