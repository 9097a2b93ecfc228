// The steady contacts of spheres, eight at a time (AVX-512) or four (AVX2): the linear spring-dashpot law with one
// global (k_n, c_n) (physics.md section 2) and optionally Coulomb friction (section 4), for the contacts
// that already touched at the last force evaluation, as the gas scenes have them. Those take no onset
// corrections; the pair loop (contact_forces.hpp) evaluates a contact's first step itself and adds every
// result in list order. Each lane does the portable code's operations in the same order
// (LinearContactLaw::force with its release charge, ContactForces::tangential_force), with correctly
// rounded roots and divisions and no multiply-add contraction, so forces, torques and springs are
// bit-identical to it.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/vec.hpp"

namespace grains::linear_contacts {

// A 3D spring is turned with its contact by the rotation taking n_before to n when 1 + n_before . n exceeds this;
// a normal reversed within one step (centres crossed) has no such rotation (0 / 0): the spring is only projected.
inline constexpr double spring_turnable = 1e-12;

// A tangential force's |F_t|^2 overflows a double from |F_t| ~ 1.3e154 (a friction.stiffness_ratio of 1e160, say),
// where |F_t| itself is finite; the Coulomb cap bound / sqrt(inf) then zeroed the force, friction off unsaid. There the
// length is taken from the force scaled by this power of two (exactly), and scaled back.
inline constexpr double overflow_rescale = 0x1p-600;

struct Input {
  const double *position, *radius, *mass, *velocity_predicted;   // positions and velocities as x, y, z triples
  const std::uint32_t* partner;                                    // each list entry's j
  const Vec<3>* shift;                                             // the 27 image shifts
  std::uint32_t* touched;                                          // per entry: the evaluation it last touched at
  std::uint32_t evaluation;
  double k, c, overlap_limit, dt;                                  // the law, the step
  bool affine;                                                     // a deforming cell: the flow counts in v_n
  double strain_rate[3], scale[3], flow_factor[3];                 // ... the step's scaling (ContactForces::flow_factor)
  // Friction, when `tangential` is set: the springs xi (x, y, z per list entry), the half-step
  // velocities and spins they advance with (x, y, z triples), k_t, c_t / c_n, mu, and whether the
  // Coulomb bound is on k_n delta (true) or on the whole normal force.
  double* tangential;
  const double *velocity, *angular_velocity;
  double friction_stiffness, friction_damping_ratio, mu;
  bool elastic_bound;
};

// The results of eight gathered pairs q .. q + 7 (q a multiple of 8), kept together so that the pair loop
// reaches every field of a pair from one address: which were evaluated here (a bit per lane), and then the
// pair's partner j, its force on j, its pair vector and, with friction, the torques to add to i and j.
struct alignas(64) Results8 {
  double f[3][8], r[3][8], torque_i[3][8], torque_j[3][8];
  std::uint32_t partner[8];
  std::uint8_t steady;
};

struct Output {
  Results8* results;   // one per eight gathered pairs
};

// Evaluates the steady contacts among the n gathered pairs (rows[q], list entries pairs[q], images[q]).
// Returns how many had their overlap clamped. `results` holds n / 8 rounded up.
// Two builds of one kernel (linear_contacts_kernel.hpp): linear_contacts_avx512.cpp (eight pairs a vector)
// and linear_contacts_avx2.cpp (four, each filling half a Results8); only where pair_filter::isa() names them.
long evaluate_avx512(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                     std::size_t n, const Output& out);
long evaluate_avx2(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                   std::size_t n, const Output& out);

}  // namespace grains::linear_contacts
