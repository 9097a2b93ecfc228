#include "core/integrator.hpp"

#include <algorithm>
#include <cmath>

#include <immintrin.h>

namespace grains::integrator_detail {
namespace {

// q <- r q for the rotation r = (c, s w), written out as a Hamilton product, then one Newton step
// back to unit length (the drift per step is O(eps)).
inline void turn_one(double c, double sx, double sy, double sz, double* q) {
  const double qx = q[0], qy = q[1], qz = q[2], qw = q[3];
  const double nx = c * qx + qw * sx + (sy * qz - sz * qy);
  const double ny = c * qy + qw * sy + (sz * qx - sx * qz);
  const double nz = c * qz + qw * sz + (sx * qy - sy * qx);
  const double nw = c * qw - (sx * qx + sy * qy + sz * qz);
  const double unit = 1.5 - 0.5 * (nx * nx + ny * ny + nz * nz + nw * nw);
  q[0] = nx * unit, q[1] = ny * unit, q[2] = nz * unit, q[3] = nw * unit;
}

inline double squared_angle(const double* w, double h2) { return (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * h2; }

// The rotation by angle t = |w| h about w: q <- (cos(t/2), sin(t/2) / t * h w) q. Per-step angles are
// tiny: below t = 1e-2 a series in t^2 (exact to double precision), above it sine and cosine.
inline void turn_by(double t2, double h, const double* w, double* q) {
  double c, s;
  if (t2 < 1e-4) {
    c = 1 - t2 * (1.0 / 8) + t2 * t2 * (1.0 / 384);
    s = (0.5 - t2 * (1.0 / 48) + t2 * t2 * (1.0 / 3840)) * h;
  } else {
    const double t = std::sqrt(t2);
    c = std::cos(0.5 * t);
    s = std::sin(0.5 * t) / t * h;
  }
  turn_one(c, s * w[0], s * w[1], s * w[2], q);
}

// Every angle below 1e-2: the series branch only, so the loop vectorises; compiled for AVX2 and the
// baseline and picked at run time (the same results: the same operations, no FMA). Not under clang's
// ThreadSanitizer: it instruments the clones' resolver, which the loader runs before the sanitizer is set up
// (every program died of SIGSEGV in __tsan_func_entry before main).
#if defined(__clang__) && defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define GRAINS_NO_CLONES
#endif
#endif
#ifndef GRAINS_NO_CLONES
__attribute__((target_clones("avx2", "default")))
#endif
void turn_small(std::size_t n, double h, const double* __restrict w, double* __restrict q) {
  const double h2 = h * h;
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i) {
    const double t2 = squared_angle(w + 3 * i, h2);
    const double c = 1 - t2 * (1.0 / 8) + t2 * t2 * (1.0 / 384);
    const double s = (0.5 - t2 * (1.0 / 48) + t2 * t2 * (1.0 / 3840)) * h;
    turn_one(c, s * w[3 * i], s * w[3 * i + 1], s * w[3 * i + 2], q + 4 * i);
  }
}

}  // namespace

// The loops of the step's two halves, written once and compiled per instruction set below. They are
// memory-bound on large systems; on a few thousand particles the arrays sit in the caches and the
// baseline build's two-double vectors left most of the time in instructions.
// Not under clang: clang 14 makes no clones of a function declared before (here, in integrator.hpp) in
// another block of its namespace. It compiled one drift_3, kick_3, ... with AVX-512's features enabled and
// no dispatch: SIGILL on processors without AVX-512 (tests/python/test_any_x86_64.py, qemu64, Nehalem,
// Haswell). The baseline code alone there: the same results, as the clones are.
#if defined(__clang__)
#define GRAINS_VECTOR_CLONES
#else
#define GRAINS_VECTOR_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#endif

// The second half kick of one component, (v + h/2 a) keep: every kick, deferred to the next step's
// first pass or not, goes through it, so a deferred kick is bit-identical to the one it replaces.
[[gnu::always_inline]] inline double second_half(double v, double h, double a, double keep) { return (v + 0.5 * h * a) * keep; }

// Component c of particle-array entry k's move from the reference position, as it is (Measure 1) or as
// the cell has carried it (Measure 2): the drift's measure and largest_move's, one expression.
template <int Measure>
[[gnu::always_inline]] inline double move_component(double x, const double* __restrict reference, std::size_t k,
                                                    double reference_lower, double strain) {
  const double r = Measure == 2 ? reference_lower + (reference[k] - reference_lower) * strain : reference[k];
  return x - r;
}

// Kick: the last step's second half (kick_body's operations, with its step hk and drag factor keep) is
// done first, in the same pass (a pending kick, see PendingKick); its velocities are summed into
// kick_witness. Follow: the particle then follows the cell (DriftGeometry). Measure: the squared distance
// of the new position from the reference position as it is (1) or as the cell has carried it (2), summed
// over the axes in order (0: none).
template <int D, int Measure, bool Follow, bool Kick>
[[gnu::always_inline]] inline DriftSums drift_body(std::size_t n, double h, const double* __restrict inverse_mass,
                                                   double* __restrict x, double* __restrict v, double* __restrict vp,
                                                   const double* __restrict f, double* __restrict f_prev,
                                                   const DriftGeometry& geometry, double hk, double keep) {
  const double* __restrict reference = geometry.reference;
  double lower[D], scale[D], reference_lower[D], strain[D];   // in registers, not reloaded through geometry
  for (int c = 0; c < D; ++c)
    lower[c] = geometry.lower[c], scale[c] = geometry.scale[c], reference_lower[c] = geometry.reference_lower[c],
    strain[c] = geometry.strain[c];
  double witness = 0, largest = 0, kicked = 0;
#pragma omp simd reduction(+ : witness, kicked) reduction(max : largest)
  for (std::size_t i = 0; i < n; ++i) {
    double moved = 0;
    for (int c = 0; c < D; ++c) {
      const std::size_t k = i * D + c;
      const double a = inverse_mass[i] * f[k], a_prev = inverse_mass[i] * f_prev[k];
      if constexpr (Kick) {
        v[k] = second_half(v[k], hk, a, keep);
        kicked += v[k];
      }
      v[k] += 0.5 * h * a;
      x[k] += h * v[k];
      vp[k] = v[k] + 0.5 * h * (1.75 * a - 0.75 * a_prev);
      f_prev[k] = 0;
      witness += x[k];
      if constexpr (Follow) x[k] = lower[c] + (x[k] - lower[c]) * scale[c];
      if constexpr (Measure > 0) {   // (x - x_ref).squaredNorm(), in Eigen's order
        const double dx = move_component<Measure>(x[k], reference, k, reference_lower[c], strain[c]);
        moved = c == 0 ? dx * dx : moved + dx * dx;
      }
    }
    if constexpr (Measure > 0) largest = std::max(largest, moved);
  }
  return {witness, largest, kicked};
}
template <int D, bool Follow, bool Kick>
[[gnu::always_inline]] inline DriftSums drift_measured(std::size_t n, double h, const double* __restrict m,
                                                       double* __restrict x, double* __restrict v, double* __restrict vp,
                                                       const double* __restrict f, double* __restrict f_prev,
                                                       const DriftGeometry& g, double hk, double keep) {
  if (!g.reference) return drift_body<D, 0, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  if (g.carried) return drift_body<D, 2, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  return drift_body<D, 1, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
}
template <int D, bool Kick>
[[gnu::always_inline]] inline DriftSums drift_any(std::size_t n, double h, const double* __restrict m, double* __restrict x,
                                                  double* __restrict v, double* __restrict vp, const double* __restrict f,
                                                  double* __restrict f_prev, const DriftGeometry& g, double hk, double keep) {
  return g.follow ? drift_measured<D, true, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep)
                  : drift_measured<D, false, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
}
#define GRAINS_DRIFT(D)                                                                                             \
  GRAINS_VECTOR_CLONES DriftSums drift_##D##_compiled(std::size_t n, double h, const double* __restrict m, double* __restrict x, \
                                           double* __restrict v, double* __restrict vp, const double* __restrict f,   \
                                           double* __restrict f_prev, const DriftGeometry& geometry,                 \
                                           const PendingKick* kick) {                                                \
    return kick ? drift_any<D, true>(n, h, m, x, v, vp, f, f_prev, geometry, kick->h, kick->keep)                  \
                : drift_any<D, false>(n, h, m, x, v, vp, f, f_prev, geometry, 0, 1);                               \
  }
GRAINS_DRIFT(3)
#undef GRAINS_DRIFT

// The 2D drift, compiled for every instruction set (the compilers vectorise it across disks, shuffling
// their x and y components apart and back).
GRAINS_VECTOR_CLONES DriftSums drift_2_compiled(std::size_t n, double h, const double* __restrict m, double* __restrict x,
                                                double* __restrict v, double* __restrict vp, const double* __restrict f,
                                                double* __restrict f_prev, const DriftGeometry& geometry,
                                                const PendingKick* kick) {
  return kick ? drift_any<2, true>(n, h, m, x, v, vp, f, f_prev, geometry, kick->h, kick->keep)
              : drift_any<2, false>(n, h, m, x, v, vp, f, f_prev, geometry, 0, 1);
}

namespace {

// The 2D drift written for AVX2: two disks a vector with their components in place (x0, y0, x1, y1), the
// mass duplicated across each disk's pair and the squared move summed pairwise. drift_body's operations in
// its order, lane by lane (no FMA), so every array it writes is bit for bit drift_body's; its witness sums
// run in another order (only their finiteness matters). On processors with AVX2 but not AVX-512 it took
// the drift from 14 % to 9 % of a pressure-controlled run of cohesive disks (type 1).
template <int Measure, bool Follow, bool Kick>
__attribute__((target("avx2"))) DriftSums drift_2_avx2_body(std::size_t n, double h, const double* __restrict inverse_mass,
                                                            double* __restrict x, double* __restrict v, double* __restrict vp,
                                                            const double* __restrict f, double* __restrict f_prev,
                                                            const DriftGeometry& g, double hk, double keep) {
  using V = __m256d;
  const V half_h = _mm256_set1_pd(0.5 * h), step = _mm256_set1_pd(h), half_hk = _mm256_set1_pd(0.5 * hk);
  const V kept = _mm256_set1_pd(keep), newer = _mm256_set1_pd(1.75), older = _mm256_set1_pd(0.75);
  // Per-axis constants, once per disk: (c_x, c_y, c_x, c_y).
  const V lower = _mm256_setr_pd(g.lower[0], g.lower[1], g.lower[0], g.lower[1]);
  const V scale = _mm256_setr_pd(g.scale[0], g.scale[1], g.scale[0], g.scale[1]);
  const V reference_lower = _mm256_setr_pd(g.reference_lower[0], g.reference_lower[1], g.reference_lower[0], g.reference_lower[1]);
  const V strain = _mm256_setr_pd(g.strain[0], g.strain[1], g.strain[0], g.strain[1]);
  V witness = _mm256_setzero_pd(), kicked = _mm256_setzero_pd(), largest = _mm256_setzero_pd();
  const std::size_t pairs = n / 2;
  for (std::size_t p = 0; p < pairs; ++p) {
    const std::size_t k = 4 * p;
    const V mass = _mm256_permute4x64_pd(_mm256_castpd128_pd256(_mm_loadu_pd(inverse_mass + 2 * p)), 0x50);
    const V a = _mm256_mul_pd(mass, _mm256_loadu_pd(f + k)), a_prev = _mm256_mul_pd(mass, _mm256_loadu_pd(f_prev + k));
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
    if constexpr (Follow) r = _mm256_add_pd(lower, _mm256_mul_pd(_mm256_sub_pd(r, lower), scale));
    _mm256_storeu_pd(x + k, r), _mm256_storeu_pd(v + k, u), _mm256_storeu_pd(vp + k, predicted);
    if constexpr (Measure > 0) {
      V ref = _mm256_loadu_pd(g.reference + k);
      if constexpr (Measure == 2) ref = _mm256_add_pd(reference_lower, _mm256_mul_pd(_mm256_sub_pd(ref, reference_lower), strain));
      const V dx = _mm256_sub_pd(r, ref), squared = _mm256_mul_pd(dx, dx);
      largest = _mm256_max_pd(_mm256_hadd_pd(squared, squared), largest);   // (x^2 + y^2) per disk; as std::max
    }
  }
  alignas(32) double w[4], kk[4], l[4];
  _mm256_store_pd(w, witness), _mm256_store_pd(kk, kicked), _mm256_store_pd(l, largest);
  DriftSums sums{(w[0] + w[1]) + (w[2] + w[3]), std::max(std::max(l[0], l[1]), std::max(l[2], l[3])), (kk[0] + kk[1]) + (kk[2] + kk[3])};
  if (n % 2) {   // the last disk as drift_body does it
    const std::size_t i = n - 1;
    DriftGeometry last = g;
    if (last.reference) last.reference += 2 * i;
    const DriftSums tail = drift_body<2, Measure, Follow, Kick>(1, h, inverse_mass + i, x + 2 * i, v + 2 * i, vp + 2 * i,
                                                                f + 2 * i, f_prev + 2 * i, last, hk, keep);
    sums.witness += tail.witness, sums.kick_witness += tail.kick_witness;
    sums.largest_move = std::max(sums.largest_move, tail.largest_move);
  }
  return sums;
}
template <bool Follow, bool Kick>
__attribute__((target("avx2"))) DriftSums drift_2_avx2_measured(std::size_t n, double h, const double* m, double* x, double* v,
                                                                double* vp, const double* f, double* f_prev,
                                                                const DriftGeometry& g, double hk, double keep) {
  if (!g.reference) return drift_2_avx2_body<0, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  if (g.carried) return drift_2_avx2_body<2, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
  return drift_2_avx2_body<1, Follow, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
}
template <bool Kick>
DriftSums drift_2_avx2_any(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                           double* f_prev, const DriftGeometry& g, double hk, double keep) {
  return g.follow ? drift_2_avx2_measured<true, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep)
                  : drift_2_avx2_measured<false, Kick>(n, h, m, x, v, vp, f, f_prev, g, hk, keep);
}

}  // namespace

bool drift_2_hand_written() {
  static const bool yes = __builtin_cpu_supports("avx2") && !__builtin_cpu_supports("avx512f");
  return yes;
}

DriftSums drift_2_avx2(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                       double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  return kick ? drift_2_avx2_any<true>(n, h, m, x, v, vp, f, f_prev, geometry, kick->h, kick->keep)
              : drift_2_avx2_any<false>(n, h, m, x, v, vp, f, f_prev, geometry, 0, 1);
}

DriftSums drift_3(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                  double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  return (first_half_avx512() ? drift_3_avx512 : drift_3_compiled)(n, h, m, x, v, vp, f, f_prev, geometry, kick);
}

DriftSums drift_2(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                  double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  if (!drift_2_hand_written()) return drift_2_compiled(n, h, m, x, v, vp, f, f_prev, geometry, kick);
  return drift_2_avx2(n, h, m, x, v, vp, f, f_prev, geometry, kick);
}

// The drift's measure alone, over positions that have already moved.
template <int D, int Measure>
[[gnu::always_inline]] inline double largest_move_body(std::size_t n, const double* __restrict x, const DriftGeometry& g) {
  const double* __restrict reference = g.reference;
  double reference_lower[D], strain[D];
  for (int c = 0; c < D; ++c) reference_lower[c] = g.reference_lower[c], strain[c] = g.strain[c];
  double largest = 0;
#pragma omp simd reduction(max : largest)
  for (std::size_t i = 0; i < n; ++i) {
    double moved = 0;
    for (int c = 0; c < D; ++c) {
      const std::size_t k = i * D + c;
      const double dx = move_component<Measure>(x[k], reference, k, reference_lower[c], strain[c]);
      moved = c == 0 ? dx * dx : moved + dx * dx;
    }
    largest = std::max(largest, moved);
  }
  return largest;
}
#define GRAINS_LARGEST_MOVE(D)                                                                            \
  GRAINS_VECTOR_CLONES double largest_move_##D(std::size_t n, const double* __restrict x, const DriftGeometry& g) { \
    return g.carried ? largest_move_body<D, 2>(n, x, g) : largest_move_body<D, 1>(n, x, g);               \
  }
GRAINS_LARGEST_MOVE(2)
GRAINS_LARGEST_MOVE(3)
#undef GRAINS_LARGEST_MOVE

// Kick: as in drift_body, the last step's pending second half first; returns the sum of those spins.
template <int S, bool Kick>
[[gnu::always_inline]] inline double half_kick_spin_body(std::size_t n, double h, const double* __restrict inverse_inertia,
                                                         double* __restrict torque, double* __restrict w, double hk,
                                                         double keep) {
  double kicked = 0;
#pragma omp simd reduction(+ : kicked)
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < S; ++c) {
      const std::size_t k = i * S + c;
      const double alpha = inverse_inertia[i] * torque[k];
      if constexpr (Kick) {
        w[k] = second_half(w[k], hk, alpha, keep);
        kicked += w[k];
      }
      w[k] += 0.5 * h * alpha;
      torque[k] = 0;
    }
  return kicked;
}
#define GRAINS_HALF_KICK_SPIN(S, NAME)                                                                               \
  GRAINS_VECTOR_CLONES double NAME(std::size_t n, double h, const double* __restrict ii,               \
                                                 double* __restrict t, double* __restrict w, const PendingKick* kick) { \
    return kick ? half_kick_spin_body<S, true>(n, h, ii, t, w, kick->h, kick->keep)                                 \
                : half_kick_spin_body<S, false>(n, h, ii, t, w, 0, 1);                                              \
  }
GRAINS_HALF_KICK_SPIN(1, half_kick_spin_1)
GRAINS_HALF_KICK_SPIN(3, half_kick_spin_3_compiled)
#undef GRAINS_HALF_KICK_SPIN

double half_kick_spin_3(std::size_t n, double h, const double* inverse_inertia, double* torque, double* w,
                        const PendingKick* kick) {
  return (first_half_avx512() ? half_kick_spin_3_avx512 : half_kick_spin_3_compiled)(n, h, inverse_inertia, torque, w, kick);
}

GRAINS_VECTOR_CLONES
void advance_any(std::size_t n, double h, double* __restrict theta, const double* __restrict w) {
#pragma omp simd
  for (std::size_t k = 0; k < n; ++k) theta[k] += h * w[k];
}

template <int C>
[[gnu::always_inline]] inline double kick_body(std::size_t n, double h, double keep, const double* __restrict inverse_mass,
                                               const double* __restrict f, double* __restrict v) {
  double witness = 0;
#pragma omp simd reduction(+ : witness)
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < C; ++c) {
      const std::size_t k = i * C + c;
      const double ak = inverse_mass[i] * f[k];
      v[k] = second_half(v[k], h, ak, keep);
      witness += v[k];
    }
  return witness;
}
#define GRAINS_KICK(C)                                                                                              \
  GRAINS_VECTOR_CLONES double kick_##C(std::size_t n, double h, double keep, const double* __restrict m,           \
                                       const double* __restrict f, double* __restrict v) {                          \
    return kick_body<C>(n, h, keep, m, f, v);                                                                       \
  }
GRAINS_KICK(1)
GRAINS_KICK(2)
GRAINS_KICK(3)
#undef GRAINS_KICK

// In particle order and without vectors across particles: the sums must be kinetic_stress's own. They run
// in a local copy of s: through s itself, which might alias the arrays read, every addition was stored and
// loaded back before the next particle's.
template <int D, bool Kick>
void add_kinetic_stress_body(std::size_t n, const double* __restrict mass, const double* __restrict inverse_mass,
                             const double* __restrict f, const double* __restrict v, double h, double keep, double* s) {
  double sum[D * D];
  for (int e = 0; e < D * D; ++e) sum[e] = s[e];
  for (std::size_t i = 0; i < n; ++i) {
    double u[D], mu[D];
    for (int c = 0; c < D; ++c) {
      const std::size_t k = i * D + c;
      u[c] = Kick ? second_half(v[k], h, inverse_mass[i] * f[k], keep) : v[k];
      mu[c] = mass[i] * u[c];
    }
    for (int c = 0; c < D; ++c)
      for (int r = 0; r < D; ++r) sum[r + D * c] += mu[r] * u[c];
  }
  for (int e = 0; e < D * D; ++e) s[e] = sum[e];
}
template <int D>
void add_kinetic_stress_any(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                            const double* v, const PendingKick* kick, double* s) {
  if (kick) add_kinetic_stress_body<D, true>(n, mass, inverse_mass, f, v, kick->h, kick->keep, s);
  else add_kinetic_stress_body<D, false>(n, mass, inverse_mass, f, v, 0, 1, s);
}
void add_kinetic_stress_2_compiled(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                                   const double* v, const PendingKick* kick, double* s) {
  add_kinetic_stress_any<2>(n, mass, inverse_mass, f, v, kick, s);
}

namespace {
// The 2D sum written for AVX2: a disk's four terms (m u_r u_c, in s's column-major order) as one vector,
// (m u_x, m u_y, m u_x, m u_y) times (u_x, u_x, u_y, u_y), added to the four sums at once. The body's
// operations lane by lane, in particle order (no FMA), so the same bits, but one chain of dependent vector
// additions where the body has four of scalar ones: in a pressure-controlled run the barostat waits for
// this sum at every step, on one thread.
template <bool Kick>
__attribute__((target("avx2"))) void add_kinetic_stress_2_avx2_body(std::size_t n, const double* __restrict mass,
                                                                    const double* __restrict inverse_mass,
                                                                    const double* __restrict f, const double* __restrict v,
                                                                    double h, double keep, double* s) {
  const __m128d half_h = _mm_set1_pd(0.5 * h), kept = _mm_set1_pd(keep);
  __m256d sum = _mm256_loadu_pd(s);
  for (std::size_t i = 0; i < n; ++i) {
    __m128d u = _mm_loadu_pd(v + 2 * i);
    if constexpr (Kick)   // second_half(v, h, inverse_mass f, keep)
      u = _mm_mul_pd(_mm_add_pd(u, _mm_mul_pd(half_h, _mm_mul_pd(_mm_set1_pd(inverse_mass[i]), _mm_loadu_pd(f + 2 * i)))), kept);
    const __m128d mu = _mm_mul_pd(_mm_set1_pd(mass[i]), u);
    const __m256d left = _mm256_insertf128_pd(_mm256_castpd128_pd256(mu), mu, 1);         // (mu_x, mu_y, mu_x, mu_y)
    const __m256d right = _mm256_permute4x64_pd(_mm256_castpd128_pd256(u), 0x50);         // (u_x, u_x, u_y, u_y)
    sum = _mm256_add_pd(sum, _mm256_mul_pd(left, right));
  }
  _mm256_storeu_pd(s, sum);
}
}  // namespace

void add_kinetic_stress_2_avx2(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                               const double* v, const PendingKick* kick, double* s) {
  if (kick) add_kinetic_stress_2_avx2_body<true>(n, mass, inverse_mass, f, v, kick->h, kick->keep, s);
  else add_kinetic_stress_2_avx2_body<false>(n, mass, inverse_mass, f, v, 0, 1, s);
}

void add_kinetic_stress_2(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                          const double* v, const PendingKick* kick, double* s) {
  static const bool avx2 = __builtin_cpu_supports("avx2");
  (avx2 ? add_kinetic_stress_2_avx2 : add_kinetic_stress_2_compiled)(n, mass, inverse_mass, f, v, kick, s);
}
void add_kinetic_stress_3(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                          const double* v, const PendingKick* kick, double* s) {
  add_kinetic_stress_any<3>(n, mass, inverse_mass, f, v, kick, s);
}

void turn(std::size_t n, double h, const double* w, double* q) {
  constexpr std::size_t block = 64;
  const double h2 = h * h;
  for (std::size_t b = 0; b < n; b += block) {
    const std::size_t m = std::min(block, n - b);
    double largest = 0;   // largest squared angle in the block
#pragma omp simd reduction(max : largest)
    for (std::size_t i = b; i < b + m; ++i) largest = std::max(largest, squared_angle(w + 3 * i, h2));
    if (largest < 1e-4) turn_small(m, h, w + 3 * b, q + 4 * b);
    else   // each particle as turn_small would, but large angles by sine and cosine
      for (std::size_t i = b; i < b + m; ++i) turn_by(squared_angle(w + 3 * i, h2), h, w + 3 * i, q + 4 * i);
  }
}

}  // namespace grains::integrator_detail
