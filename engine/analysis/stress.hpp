// The stress tensor of a periodic cell (physics.md section 9), compressive positive:
//   sigma = (1/V) sum_pairs F_ij (x) r_ij  +  (1/V) sum_i m_i v_i (x) v_i,
// the contact part from the virial the pair loops accumulate (System::virial), the kinetic part from
// the velocities (relative to the affine flow of a deforming cell). V is the area in 2D.
#pragma once
#include "core/integrator.hpp"
#include "core/particles.hpp"

namespace grains {

template <int D> using Tensor = Eigen::Matrix<double, D, D>;

template <int D>
Tensor<D> contact_stress(const Tensor<D>& virial, double volume) {
  return virial / volume;
}

// The sum in particle order, by the integrator's add_kinetic_stress: a simulation on one thread forms the
// same sum (on several, each thread's particles in order, the threads' sums in thread order), and its barostat
// that of the velocities a pending kick will give between the steps of a run.
template <int D>
Tensor<D> kinetic_stress(const Particles<D>& P, double volume) {
  Tensor<D> s = Tensor<D>::Zero();
  add_kinetic_stress<D>(P, 0, P.size(), nullptr, s);
  return s / volume;
}

// Mean normal stress: the pressure.
template <int D>
double pressure(const Tensor<D>& stress) {
  return stress.trace() / D;
}

}  // namespace grains
