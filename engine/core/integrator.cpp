#include "core/integrator.hpp"
#include "core/integrator_loops.hpp"

#include <algorithm>
#include <cmath>

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

// The drift compiled for every instruction set (the compilers vectorise it across particles, shuffling their
// components apart and back).
#define GRAINS_DRIFT(D)                                                                                                \
  GRAINS_VECTOR_CLONES DriftSums drift_##D##_compiled(std::size_t n, double h, const double* __restrict m,              \
                                                      double* __restrict x, double* __restrict v,                       \
                                                      double* __restrict vp, const double* __restrict f,                \
                                                      double* __restrict f_prev, const DriftGeometry& geometry,         \
                                                      const PendingKick* kick) {                                        \
    return kick ? drift_any<D, true>(n, h, m, x, v, vp, f, f_prev, geometry, kick->h, kick->keep)                     \
                : drift_any<D, false>(n, h, m, x, v, vp, f, f_prev, geometry, 0, 1);                                  \
  }
GRAINS_DRIFT(2)
GRAINS_DRIFT(3)
#undef GRAINS_DRIFT

// The loops written for AVX2 wherever the processor has it (integrator_avx2.cpp).
DriftSums drift_2(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                  double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  return (has_avx2() ? drift_2_avx2 : drift_2_compiled)(n, h, m, x, v, vp, f, f_prev, geometry, kick);
}
DriftSums drift_3(std::size_t n, double h, const double* m, double* x, double* v, double* vp, const double* f,
                  double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  return (has_avx2() ? drift_3_avx2 : drift_3_compiled)(n, h, m, x, v, vp, f, f_prev, geometry, kick);
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

#define GRAINS_HALF_KICK_SPIN(S, NAME)                                                                        \
  GRAINS_VECTOR_CLONES double NAME(std::size_t n, double h, const double* __restrict ii, double* __restrict t, \
                                   double* __restrict w, const PendingKick* kick) {                            \
    return kick ? half_kick_spin_body<S, true>(n, h, ii, t, w, kick->h, kick->keep)                            \
                : half_kick_spin_body<S, false>(n, h, ii, t, w, 0, 1);                                         \
  }
GRAINS_HALF_KICK_SPIN(1, half_kick_spin_1)
GRAINS_HALF_KICK_SPIN(3, half_kick_spin_3_compiled)
#undef GRAINS_HALF_KICK_SPIN

double half_kick_spin_3(std::size_t n, double h, const double* inverse_inertia, double* torque, double* w,
                        const PendingKick* kick) {
  return (has_avx2() ? half_kick_spin_3_avx2 : half_kick_spin_3_compiled)(n, h, inverse_inertia, torque, w, kick);
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

void add_kinetic_stress_2(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                          const double* v, const PendingKick* kick, double* s) {
  (has_avx2() ? add_kinetic_stress_2_avx2 : add_kinetic_stress_2_compiled)(n, mass, inverse_mass, f, v, kick, s);
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
