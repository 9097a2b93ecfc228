// The scalar bodies of the integrator's per-particle passes, one particle component after another: compiled
// per instruction set in integrator.cpp (the compilers vectorise them across particles), and the loops written
// for AVX2 (integrator_avx2.cpp) finish a run's last particles with them. Their operations, in their order and
// without contraction (both files are compiled with -ffp-contract=off), define the bits every build writes.
#pragma once
#include <algorithm>
#include <cstddef>

#include "core/integrator.hpp"

namespace grains::integrator_detail {

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

}  // namespace grains::integrator_detail
