// Velocity Verlet for translation and rotation, split around the force evaluation.
// Between the two halves, `velocity` holds v(t + h/2) (which moved the positions and feeds the
// tangential springs) and `velocity_predicted` a third-order estimate of v(t + h) for the dashpots:
//   v(t+h) ~ v(t+h/2) + h/2 (7/4 a_n - 3/4 a_{n-1}).
// The accelerations are never stored: a = f / m is formed where it is used, from `force` (f_n) and
// `force_prev` (f_{n-1}); the two arrays swap roles every step, so no array is copied or cleared apart.
// Inside a run of steps the second half kick is done by the next step's first pass (core/pending_kick.hpp).
#pragma once
#include <cmath>
#include <utility>
#include <vector>

#include "core/particles.hpp"
#include "core/pending_kick.hpp"
#include "core/thread_share.hpp"

namespace grains {

namespace integrator_detail {

// An array of fixed-size vectors as the plain doubles it holds, so that the kernels below run over
// unaliased flat arrays (the compiler then keeps everything in registers and vectorises).
template <class V> double* flat(std::vector<V>& v) {
  static_assert(sizeof(V) == V::SizeAtCompileTime * sizeof(double));
  return reinterpret_cast<double*>(v.data());
}
template <class V> const double* flat(const std::vector<V>& v) {
  static_assert(sizeof(V) == V::SizeAtCompileTime * sizeof(double));
  return reinterpret_cast<const double*>(v.data());
}

// The kernels below are compiled for AVX-512, AVX2 and the baseline, picked at run time
// (integrator.cpp). Every clone does the same operations in the same order (no multiply-add
// contraction), so the results do not depend on the processor; only the order of the witness sums does.

// What the first half also does with the positions it moves, for a particle pass (per axis, up to 3).
struct DriftGeometry {
  // The particles follow a cell that has just been rescaled about `lower`: x = lower + (x - lower) scale.
  bool follow = false;
  double lower[3] = {}, scale[3] = {};
  // Given the neighbour list's reference positions (else null): the largest squared displacement from
  // them, as the cell has carried them (NeighbourList::Reference: reference_lower + (r - reference_lower)
  // strain; r itself while `carried` is false, the strain being 1).
  const double* reference = nullptr;
  bool carried = false;
  double reference_lower[3] = {}, strain[3] = {};
};

// First half over n particles of D components: a = f / m, a_prev = f_prev / m; v += h/2 a; x += h v;
// vp = v + h/2 (7/4 a - 3/4 a_prev); then f_prev is cleared: it collects the coming force evaluation
// (its line is in the cache already). Returns the sum of the drifted x (only its finiteness matters, so
// the order of the sum is free). The same pass moves the particles with the cell and measures their
// largest move (DriftGeometry): one pass over the positions instead of three. Given a pending kick (else
// null), the last step's second half (kick, below) is done first in the same pass, and the sum of its
// velocities returned as kick_witness.
struct DriftSums {
  double witness = 0, largest_move = 0, kick_witness = 0;
};
// The drift's largest squared move alone (geometry.reference set; follow unused), over n particles'
// positions x: the same value the drift that moved them to x would have measured.
double largest_move_2(std::size_t n, const double* x, const DriftGeometry& geometry);
double largest_move_3(std::size_t n, const double* x, const DriftGeometry& geometry);
DriftSums drift_2(std::size_t n, double h, const double* __restrict inverse_mass, double* __restrict x,
                  double* __restrict v, double* __restrict vp, const double* __restrict f, double* __restrict f_prev,
                  const DriftGeometry& geometry, const PendingKick* kick);
DriftSums drift_3(std::size_t n, double h, const double* __restrict inverse_mass, double* __restrict x,
                  double* __restrict v, double* __restrict vp, const double* __restrict f, double* __restrict f_prev,
                  const DriftGeometry& geometry, const PendingKick* kick);
// drift_2 and drift_3 run the loops written for AVX2 (core/integrator_avx2.cpp) wherever the processor has
// it (has_avx2; on Zen 4 they beat the compiled AVX-512 loops), else their _compiled twins, the loops the
// compilers vectorise for each instruction set. Both write the same bits (tests compare them).
bool has_avx2();
DriftSums drift_2_avx2(std::size_t n, double h, const double* __restrict inverse_mass, double* __restrict x,
                       double* __restrict v, double* __restrict vp, const double* __restrict f, double* __restrict f_prev,
                       const DriftGeometry& geometry, const PendingKick* kick);
DriftSums drift_2_compiled(std::size_t n, double h, const double* __restrict inverse_mass, double* __restrict x,
                           double* __restrict v, double* __restrict vp, const double* __restrict f, double* __restrict f_prev,
                           const DriftGeometry& geometry, const PendingKick* kick);
DriftSums drift_3_avx2(std::size_t n, double h, const double* __restrict inverse_mass, double* __restrict x,
                       double* __restrict v, double* __restrict vp, const double* __restrict f, double* __restrict f_prev,
                       const DriftGeometry& geometry, const PendingKick* kick);
DriftSums drift_3_compiled(std::size_t n, double h, const double* __restrict inverse_mass, double* __restrict x,
                           double* __restrict v, double* __restrict vp, const double* __restrict f, double* __restrict f_prev,
                           const DriftGeometry& geometry, const PendingKick* kick);
template <int D>
DriftSums drift(std::size_t n, double h, const double* inverse_mass, double* x, double* v, double* vp, const double* f,
                double* f_prev, const DriftGeometry& geometry, const PendingKick* kick) {
  static_assert(D == 2 || D == 3);
  if constexpr (D == 2) return drift_2(n, h, inverse_mass, x, v, vp, f, f_prev, geometry, kick);
  else return drift_3(n, h, inverse_mass, x, v, vp, f, f_prev, geometry, kick);
}

// First half for the spins of n particles of S components (1: disks, 3: spheres): w += h/2 alpha with
// alpha = torque / I (the same product the second half formed), then the torque is cleared for the
// coming force evaluation (its line is in the cache already). No prediction of w(t + h): the torques
// all act on the half-step spin. Given a pending kick, as drift: returns the sum of its spins (else 0).
double half_kick_spin_1(std::size_t n, double h, const double* __restrict inverse_inertia, double* __restrict torque,
                        double* __restrict w, const PendingKick* kick);
double half_kick_spin_3(std::size_t n, double h, const double* __restrict inverse_inertia, double* __restrict torque,
                        double* __restrict w, const PendingKick* kick);
// half_kick_spin_3 runs half_kick_spin_3_avx2 wherever the processor has AVX2, as drift_3.
double half_kick_spin_3_avx2(std::size_t n, double h, const double* __restrict inverse_inertia, double* __restrict torque,
                             double* __restrict w, const PendingKick* kick);
double half_kick_spin_3_compiled(std::size_t n, double h, const double* __restrict inverse_inertia,
                                 double* __restrict torque, double* __restrict w, const PendingKick* kick);
template <int S>
double half_kick_spin(std::size_t n, double h, const double* inverse_inertia, double* torque, double* w,
                      const PendingKick* kick) {
  static_assert(S == 1 || S == 3);
  if constexpr (S == 1) return half_kick_spin_1(n, h, inverse_inertia, torque, w, kick);
  else return half_kick_spin_3(n, h, inverse_inertia, torque, w, kick);
}

// 2D orientations: theta += h w over n disks.
void advance_any(std::size_t n, double h, double* __restrict theta, const double* __restrict w);
inline void advance(std::size_t n, double h, double* theta, const double* w) { advance_any(n, h, theta, w); }

// Turn n orientations q (quaternions stored x, y, z, w) by the rotations of angle |w| h about w.
void turn(std::size_t n, double h, const double* w, double* q);

// Second half over n particles of C components: v = (v + h/2 f / m) keep, keep = exp(-gamma h) for a drag
// of rate gamma (1 without: x * 1 is x exactly); m: the mass or, for spins, the moment of inertia.
// Returns the sum of the new v (in any order, like drift's: a sum in loop order would chain every add
// and keep the loop scalar).
double kick_1(std::size_t n, double h, double keep, const double* __restrict inverse_mass, const double* __restrict f,
              double* __restrict v);
double kick_2(std::size_t n, double h, double keep, const double* __restrict inverse_mass, const double* __restrict f,
              double* __restrict v);
double kick_3(std::size_t n, double h, double keep, const double* __restrict inverse_mass, const double* __restrict f,
              double* __restrict v);
template <int C>
double kick(std::size_t n, double h, double keep, const double* inverse_mass, const double* f, double* v) {
  static_assert(C >= 1 && C <= 3);
  if constexpr (C == 1) return kick_1(n, h, keep, inverse_mass, f, v);
  else if constexpr (C == 2) return kick_2(n, h, keep, inverse_mass, f, v);
  else return kick_3(n, h, keep, inverse_mass, f, v);
}

// Adds sum m u u^T over n particles into s (D x D, column-major), in particle order, u being the
// velocity the pending kick will give (its second half, the operations of kick) or, without one, the
// stored velocity: the barostat reads the kinetic stress while the kick is still pending, bit for bit
// the kinetic_stress (analysis/stress.hpp) of the kicked velocities.
// In 2D, a loop written for AVX2 (add_kinetic_stress_2_avx2) where the processor has it, else the compiled
// one: both give the same bits (tested).
void add_kinetic_stress_2(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                          const double* v, const PendingKick* kick, double* s);
void add_kinetic_stress_2_avx2(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                               const double* v, const PendingKick* kick, double* s);
void add_kinetic_stress_2_compiled(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                                   const double* v, const PendingKick* kick, double* s);
void add_kinetic_stress_3(std::size_t n, const double* mass, const double* inverse_mass, const double* f,
                          const double* v, const PendingKick* kick, double* s);

}  // namespace integrator_detail

// First half over the particles [b, e), one thread's share (core/thread_share.hpp): the step runs it
// inside a parallel region it shares with the other per-particle work of the step's first half.
// Rotate = false skips every angular array: a scene without torques and without initial spin
// never reads or writes them (half the memory traffic of the step). The older forces and, with Rotate,
// the torques are cleared here for the coming evaluation; the caller then swaps force and force_prev.
// Both halves are memory-bound: each array is read or written once.
// Returns the sum of the drifted positions' components, a cheap witness (finite exactly when every
// position is), and with geometry.reference (the whole system's, indexed by particle) the largest squared
// move from it; the particles follow the cell if geometry says so. Given a pending kick (else null), the
// last step's second half is done first, in the same pass, and the sum of its velocities and spins
// returned as kick_witness. Orient = false leaves the orientations alone (particles.track_orientation = false).
template <int D, bool Rotate, bool Orient = true>
integrator_detail::DriftSums kick_drift_predict(Particles<D>& P, double h, std::size_t b, std::size_t e,
                                                const integrator_detail::DriftGeometry& geometry,
                                                const PendingKick* kick = nullptr) {
  using namespace integrator_detail;
  DriftGeometry range = geometry;
  if (range.reference) range.reference += D * b;
  DriftSums sums =
      drift<D>(e - b, h, P.inv_mass.data() + b, flat(P.position) + D * b, flat(P.velocity) + D * b,
               flat(P.velocity_predicted) + D * b, flat(P.force) + D * b, flat(P.force_prev) + D * b, range, kick);
  constexpr int S = Spin<D>::SizeAtCompileTime;
  if constexpr (Rotate)
    sums.kick_witness += half_kick_spin<S>(e - b, h, P.inv_inertia.data() + b, flat(P.torque) + S * b,
                                           flat(P.angular_velocity) + S * b, kick);
  if constexpr (Rotate && Orient && D == 3) {
    static_assert(sizeof(Eigen::Quaterniond) == 4 * sizeof(double));
    turn(e - b, h, flat(P.angular_velocity) + 3 * b, reinterpret_cast<double*>(P.orientation.data()) + 4 * b);
  } else if constexpr (Rotate && Orient) {   // 2D: the angle simply advances
    advance(e - b, h, P.orientation.data() + b, flat(P.angular_velocity) + b);
  }
  return sums;
}

// Second half kick of the particles [b, e) from the new forces, velocities and spins then multiplied by
// `keep` (a drag, see kick). Returns the sum of their velocities' and spins' components: finite exactly
// when every one is.
template <int D, bool Rotate>
double kick_range(Particles<D>& P, double h, double keep, std::size_t b, std::size_t e) {
  using namespace integrator_detail;
  constexpr int S = Spin<D>::SizeAtCompileTime;
  double witness = kick<D>(e - b, h, keep, P.inv_mass.data() + b, flat(P.force) + D * b, flat(P.velocity) + D * b);
  if constexpr (Rotate)
    witness += kick<S>(e - b, h, keep, P.inv_inertia.data() + b, flat(P.torque) + S * b, flat(P.angular_velocity) + S * b);
  return witness;
}

// The kinetic stress sum (without the 1/V) of the particles [b, e), added into s, of the velocities
// after the pending kick, if one is given (integrator_detail::add_kinetic_stress).
template <int D>
void add_kinetic_stress(const Particles<D>& P, std::size_t b, std::size_t e, const PendingKick* kick,
                        Eigen::Matrix<double, D, D>& s) {
  using namespace integrator_detail;
  const auto add = D == 2 ? add_kinetic_stress_2 : add_kinetic_stress_3;
  add(e - b, P.mass.data() + b, P.inv_mass.data() + b, flat(P.force) + D * b, flat(P.velocity) + D * b, kick, s.data());
}

// Particle p's velocity (or spin) is about to change while a kick is pending: it is kicked now, as the
// pending kick would have kicked it (kick_range on it alone), and left out of that kick later.
template <int D>
void kick_early(Particles<D>& P, PendingKick& pending, std::size_t p) {
  if (!pending.active || pending.kicked[p]) return;
  pending.early_witness += pending.spins ? kick_range<D, true>(P, pending.h, pending.keep, p, p + 1)
                                         : kick_range<D, false>(P, pending.h, pending.keep, p, p + 1);
  pending.kicked[p] = 1;
  pending.early.push_back(std::uint32_t(p));
}

}  // namespace grains
