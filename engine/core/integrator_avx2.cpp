// The integrator's passes written for AVX2 (integrator.hpp says where each one runs): the drift in 2D and
// 3D, the spheres' spin half kick and the 2D kinetic stress sum.
//
// The compilers vectorise drift_body across particles, pulling every array's components apart with
// permutes and putting them back; yet every operation but one is per component. So here the arrays are
// read as they lie, four components a vector (four particles in D vectors), and only the per-particle
// factor (1/m, 1/I) and the squared move are rearranged. On the AMD EPYC (Zen 4), 17,576 spheres: 1.8-3.1
// ns a sphere (by the arrays' alignment) against the compiled AVX-512 loop's 3.9-4.5 (an AVX-512 version of
// this loop: 2.6-3.6, and slower in whole runs, so not kept); 1,400-70,000 disks: 1.2-1.9 ns against 1.3-2.1
// (docs/speed.md). The compiled loops' operations lane by lane (no FMA: this file is compiled without
// contraction), so every array written is bit for bit theirs; the witness sums run in another order (only
// their finiteness matters). A run's last few particles go through the scalar bodies (integrator_loops.hpp).
#include <algorithm>

#include <immintrin.h>

#include "core/integrator.hpp"
#include "core/integrator_loops.hpp"

#define GRAINS_AVX2_PASS __attribute__((target("avx2")))

namespace grains::integrator_detail {
namespace {

using V = __m256d;

// Four particles' components in D vectors: component k (of the 4 D) belongs to particle k / D.
// A per-particle value p laid out so: (p0 p0 p1 p1) (p2 p2 p3 p3), or (p0 p0 p0 p1) (p1 p1 p2 p2) (p2 p3 p3 p3).
template <int D>
GRAINS_AVX2_PASS inline void spread(V p, V out[D]) {
  if constexpr (D == 2) {
    out[0] = _mm256_permute4x64_pd(p, 0x50), out[1] = _mm256_permute4x64_pd(p, 0xFA);
  } else {
    out[0] = _mm256_permute4x64_pd(p, 0x40), out[1] = _mm256_permute4x64_pd(p, 0xA5), out[2] = _mm256_permute4x64_pd(p, 0xFE);
  }
}

// Each particle's s_x + s_y (+ s_z), added in that order, in some order of the particles.
template <int D>
GRAINS_AVX2_PASS inline V particle_sums(const V s[D]) {
  if constexpr (D == 2) {
    return _mm256_hadd_pd(s[0], s[1]);
  } else {   // from (x0 y0 z0 x1) (y1 z1 x2 y2) (z2 x3 y3 z3): each axis's four by two blends
    const V x = _mm256_blend_pd(_mm256_blend_pd(s[0], s[1], 0b0100), s[2], 0b0010);   // x0 x3 x2 x1
    const V y = _mm256_blend_pd(_mm256_blend_pd(s[0], s[1], 0b1001), s[2], 0b0100);   // y1 y0 y3 y2
    const V z = _mm256_blend_pd(_mm256_blend_pd(s[0], s[1], 0b0010), s[2], 0b1001);   // z2 z1 z0 z3
    return _mm256_add_pd(_mm256_add_pd(_mm256_permute4x64_pd(x, 0x6C), _mm256_permute4x64_pd(y, 0xB1)),
                         _mm256_permute4x64_pd(z, 0xC6));
  }
}

// A per-axis constant c[0 .. D - 1] as the components lie: vector j lane l holds c[(4 j + l) % D].
template <int D>
GRAINS_AVX2_PASS inline void per_axis(const double* c, V out[D]) {
  for (int j = 0; j < D; ++j) out[j] = _mm256_setr_pd(c[(4 * j) % D], c[(4 * j + 1) % D], c[(4 * j + 2) % D], c[(4 * j + 3) % D]);
}

GRAINS_AVX2_PASS inline double lane_sum(V v) {
  const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}
GRAINS_AVX2_PASS inline double lane_max(V v) {
  const __m128d pair = _mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_max_sd(pair, _mm_unpackhi_pd(pair, pair)));
}

template <int D, int Measure, bool Follow, bool Kick>
GRAINS_AVX2_PASS DriftSums drift_vectors(std::size_t n, double h, const double* __restrict inverse_mass, double* __restrict x,
                                      double* __restrict v, double* __restrict vp, const double* __restrict f,
                                      double* __restrict f_prev, const DriftGeometry& g, double hk, double keep) {
  const V half_h = _mm256_set1_pd(0.5 * h), step = _mm256_set1_pd(h), half_hk = _mm256_set1_pd(0.5 * hk);
  const V kept = _mm256_set1_pd(keep), newer = _mm256_set1_pd(1.75), older = _mm256_set1_pd(0.75);
  V lower[D], scale[D], reference_lower[D], strain[D];
  per_axis<D>(g.lower, lower), per_axis<D>(g.scale, scale);
  per_axis<D>(g.reference_lower, reference_lower), per_axis<D>(g.strain, strain);
  V witness = _mm256_setzero_pd(), kicked = _mm256_setzero_pd(), largest = _mm256_setzero_pd();
  const std::size_t blocks = n / 4;
  for (std::size_t b = 0; b < blocks; ++b) {
    V mass[D], squared[D];
    spread<D>(_mm256_loadu_pd(inverse_mass + 4 * b), mass);
    for (int j = 0; j < D; ++j) {
      const std::size_t k = 4 * D * b + 4 * j;
      const V a = _mm256_mul_pd(mass[j], _mm256_loadu_pd(f + k)), a_prev = _mm256_mul_pd(mass[j], _mm256_loadu_pd(f_prev + k));
      V u = _mm256_loadu_pd(v + k);
      if constexpr (Kick) {
        u = _mm256_mul_pd(_mm256_add_pd(u, _mm256_mul_pd(half_hk, a)), kept);   // second_half
        kicked = _mm256_add_pd(kicked, u);
      }
      u = _mm256_add_pd(u, _mm256_mul_pd(half_h, a));
      V r = _mm256_add_pd(_mm256_loadu_pd(x + k), _mm256_mul_pd(step, u));
      const V predicted = _mm256_add_pd(u, _mm256_mul_pd(half_h, _mm256_sub_pd(_mm256_mul_pd(newer, a), _mm256_mul_pd(older, a_prev))));
      _mm256_storeu_pd(f_prev + k, _mm256_setzero_pd());
      witness = _mm256_add_pd(witness, r);
      if constexpr (Follow) r = _mm256_add_pd(lower[j], _mm256_mul_pd(_mm256_sub_pd(r, lower[j]), scale[j]));
      _mm256_storeu_pd(x + k, r), _mm256_storeu_pd(v + k, u), _mm256_storeu_pd(vp + k, predicted);
      if constexpr (Measure > 0) {
        V ref = _mm256_loadu_pd(g.reference + k);
        if constexpr (Measure == 2)
          ref = _mm256_add_pd(reference_lower[j], _mm256_mul_pd(_mm256_sub_pd(ref, reference_lower[j]), strain[j]));
        const V dx = _mm256_sub_pd(r, ref);
        squared[j] = _mm256_mul_pd(dx, dx);
      }
    }
    if constexpr (Measure > 0) largest = _mm256_max_pd(particle_sums<D>(squared), largest);   // as std::max(largest, moved)
  }
  DriftSums sums{lane_sum(witness), lane_max(largest), lane_sum(kicked)};
  if (const std::size_t done = 4 * blocks; done < n) {
    DriftGeometry rest = g;
    if (rest.reference) rest.reference += D * done;
    const DriftSums tail = drift_body<D, Measure, Follow, Kick>(n - done, h, inverse_mass + done, x + D * done, v + D * done,
                                                                vp + D * done, f + D * done, f_prev + D * done, rest, hk, keep);
    sums.witness += tail.witness, sums.kick_witness += tail.kick_witness;
    sums.largest_move = std::max(sums.largest_move, tail.largest_move);
  }
  return sums;
}

template <int D, bool Follow, bool Kick>
DriftSums drift_measured(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                         double* f_prev, const DriftGeometry& g, double hk, double keep) {
  if (!g.reference) return drift_vectors<D, 0, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  if (g.carried) return drift_vectors<D, 2, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  return drift_vectors<D, 1, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
}

template <int D>
DriftSums drift_any(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                    double* f_prev, const DriftGeometry& g, const PendingKick* kick) {
  if (kick) return g.follow ? drift_measured<D, true, true>(n, h, m, x, v, vp, f, f_prev, g, kick->h, kick->keep)
                            : drift_measured<D, false, true>(n, h, m, x, v, vp, f, f_prev, g, kick->h, kick->keep);
  return g.follow ? drift_measured<D, true, false>(n, h, m, x, v, vp, f, f_prev, g, 0, 1)
                  : drift_measured<D, false, false>(n, h, m, x, v, vp, f, f_prev, g, 0, 1);
}

// half_kick_spin_body's operations on the spheres' spins as they lie.
template <bool Kick>
GRAINS_AVX2_PASS double half_kick_spin_3_vectors(std::size_t n, double h, const double* __restrict inverse_inertia,
                                              double* __restrict torque, double* __restrict w, double hk, double keep) {
  const V half_h = _mm256_set1_pd(0.5 * h), half_hk = _mm256_set1_pd(0.5 * hk), kept = _mm256_set1_pd(keep);
  V kicked = _mm256_setzero_pd();
  const std::size_t blocks = n / 4;
  for (std::size_t b = 0; b < blocks; ++b) {
    V inertia[3];
    spread<3>(_mm256_loadu_pd(inverse_inertia + 4 * b), inertia);
    for (int j = 0; j < 3; ++j) {
      const std::size_t k = 12 * b + 4 * j;
      const V alpha = _mm256_mul_pd(inertia[j], _mm256_loadu_pd(torque + k));
      V u = _mm256_loadu_pd(w + k);
      if constexpr (Kick) {
        u = _mm256_mul_pd(_mm256_add_pd(u, _mm256_mul_pd(half_hk, alpha)), kept);   // second_half
        kicked = _mm256_add_pd(kicked, u);
      }
      _mm256_storeu_pd(w + k, _mm256_add_pd(u, _mm256_mul_pd(half_h, alpha)));
      _mm256_storeu_pd(torque + k, _mm256_setzero_pd());
    }
  }
  double sum = lane_sum(kicked);
  if (const std::size_t done = 4 * blocks; done < n) {
    sum += half_kick_spin_body<3, Kick>(n - done, h, inverse_inertia + done, torque + 3 * done, w + 3 * done, hk, keep);
  }
  return sum;
}

// The 2D sum: a disk's four terms (m u_r u_c, in s's column-major order) as one vector, (m u_x, m u_y,
// m u_x, m u_y) times (u_x, u_x, u_y, u_y), added to the four sums at once. The compiled loop's operations
// lane by lane, in particle order (no FMA), so the same bits, but one chain of dependent vector additions
// where it has four of scalar ones: in a pressure-controlled run the barostat waits for this sum at every
// step, on one thread.
template <bool Kick>
GRAINS_AVX2_PASS void add_kinetic_stress_2_body(std::size_t n, const double* __restrict mass, const double* __restrict inverse_mass,
                                                const double* __restrict f, const double* __restrict v, double h, double keep,
                                                double* s) {
  const __m128d half_h = _mm_set1_pd(0.5 * h), kept = _mm_set1_pd(keep);
  V sum = _mm256_loadu_pd(s);
  for (std::size_t i = 0; i < n; ++i) {
    __m128d u = _mm_loadu_pd(v + 2 * i);
    if constexpr (Kick)   // second_half(v, h, inverse_mass f, keep)
      u = _mm_mul_pd(_mm_add_pd(u, _mm_mul_pd(half_h, _mm_mul_pd(_mm_set1_pd(inverse_mass[i]), _mm_loadu_pd(f + 2 * i)))), kept);
    const __m128d mu = _mm_mul_pd(_mm_set1_pd(mass[i]), u);
    const V left = _mm256_insertf128_pd(_mm256_castpd128_pd256(mu), mu, 1);   // (mu_x, mu_y, mu_x, mu_y)
    const V right = _mm256_permute4x64_pd(_mm256_castpd128_pd256(u), 0x50);   // (u_x, u_x, u_y, u_y)
    sum = _mm256_add_pd(sum, _mm256_mul_pd(left, right));
  }
  _mm256_storeu_pd(s, sum);
}

}  // namespace

bool has_avx2() {
  static const bool yes = __builtin_cpu_supports("avx2");
  return yes;
}

DriftSums drift_2_avx2(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                       double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  return drift_any<2>(n, h, m, x, v, vp, f, f_prev, geometry, kick);
}

DriftSums drift_3_avx2(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                       double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  return drift_any<3>(n, h, m, x, v, vp, f, f_prev, geometry, kick);
}

double half_kick_spin_3_avx2(std::size_t n, double h, const double* inverse_inertia, double* torque, double* w,
                             const PendingKick* kick) {
  return kick ? half_kick_spin_3_vectors<true>(n, h, inverse_inertia, torque, w, kick->h, kick->keep)
              : half_kick_spin_3_vectors<false>(n, h, inverse_inertia, torque, w, 0, 1);
}

void add_kinetic_stress_2_avx2(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                               const double* v, const PendingKick* kick, double* s) {
  if (kick) add_kinetic_stress_2_body<true>(n, mass, inverse_mass, f, v, kick->h, kick->keep, s);
  else add_kinetic_stress_2_body<false>(n, mass, inverse_mass, f, v, 0, 1, s);
}

}  // namespace grains::integrator_detail
