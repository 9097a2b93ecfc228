// The four equilibrium criteria of physics.md section 9, as ratios to their thresholds' scales.
// With F1 = max(F0, P a^(D-1)): every net force < tol_force F1, every net torque < tol_torque F1 a,
// |sigma_aa - P| < tol_stress F1 / a^(D-1), kinetic energy per grain < tol_kinetic F1 a.
// One O(N) pass over arrays the step has already filled: cheap enough to check every few steps.
// The kinetic energy is the translational one (velocities relative to the affine flow): a rattler
// spinning freely in its cage keeps its spin for ever and would block the test, while the rotation of
// a grain in contact is already held by the force and torque criteria.
#pragma once
#include <algorithm>
#include <cmath>

#include "analysis/stress.hpp"
#include "core/particles.hpp"

namespace grains {

struct EquilibriumTolerances {
  double force = 1e-5, torque = 1e-5, stress = 1e-5, kinetic = 5e-8;
};

// Each measure is already divided by its scale (F1, F1 a, F1 / a^(D-1), F1 a): compare with the tolerances.
struct EquilibriumMeasures {
  double force = 0, torque = 0, stress = 0, kinetic = 0;
  bool within(const EquilibriumTolerances& t) const {
    return force < t.force && torque < t.torque && stress < t.stress && kinetic < t.kinetic;
  }
};

template <int D>
EquilibriumMeasures measure_equilibrium(const Particles<D>& P, const Tensor<D>& stress, double target_pressure,
                                        double force_unit, double length_unit) {
  const double area_unit = std::pow(length_unit, D - 1);
  const double F1 = std::max(force_unit, target_pressure * area_unit);
  double f2 = 0, q2 = 0, kinetic = 0;
  for (std::size_t i = 0; i < P.size(); ++i) {
    f2 = std::max(f2, P.force[i].squaredNorm());
    q2 = std::max(q2, P.torque[i].squaredNorm());
    kinetic += 0.5 * P.mass[i] * P.velocity[i].squaredNorm();
  }
  double ds = 0;
  for (int a = 0; a < D; ++a) ds = std::max(ds, std::abs(stress(a, a) - target_pressure));
  EquilibriumMeasures m;
  m.force = std::sqrt(f2) / F1;
  m.torque = std::sqrt(q2) / (F1 * length_unit);
  m.stress = ds * area_unit / F1;
  m.kinetic = P.size() ? kinetic / double(P.size()) / (F1 * length_unit) : 0;
  return m;
}

}  // namespace grains
