// The steady contacts of cohesive disks, eight at a time (AVX-512) or four (AVX2): the consolidation scene's law in 2D
// (adhesion, friction, optionally rolling resistance; physics.md sections 4-6) for the contacts that
// already touched at the last force evaluation and do not part within the step. Those take no onset or
// parting corrections, so each is the same straight-line arithmetic; the pair loop (contact_forces.hpp)
// evaluates a contact's first step and a parting contact (its stamp left as it was for it) itself, and the
// attraction across gaps where the AVX2 build runs (the AVX-512 one evaluates it too: Results8::ready), and
// adds every result in list order. Each lane does the portable
// code's operations in the same order, with correctly rounded roots and divisions and no multiply-add
// contraction (engine/CMakeLists.txt), so the forces, torques and springs are bit-identical to it.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/vec.hpp"

namespace grains::cohesive_contacts {

struct Input {
  // Particle arrays (positions and velocities as x, y pairs).
  const double *position, *radius, *velocity_predicted, *velocity, *angular_velocity;
  // Neighbour list: partner of each entry, the image shifts.
  const std::uint32_t* partner;
  const Vec<2>* shift;
  // Per entry: the evaluation at which the pair last touched (a steady contact's is evaluation - 1),
  // the tangential spring (along z x n) and the rolling spring (null without rolling resistance).
  std::uint32_t* touched;
  std::uint32_t evaluation;
  double *tangential, *rolling_angle;
  // Per entry: the pair's c_n (AdhesiveContactLaw::damping of its masses).
  const double* damping;
  // The entries are the shell's slots (contact_forces.hpp): each batch's are consecutive, so the per-entry
  // arrays above (partner included) are loaded and stored as vectors rather than gathered and scattered,
  // and the pairs' radii are read per slot too: slot_radius[0][k] = R_i, slot_radius[1][k] = R_j.
  bool dense = false;
  const double* slot_radius[2] = {nullptr, nullptr};
  // Dense batches of eight: the velocities read by plain loads, not gathered (pair_filter::vector_loads).
  bool vector_loads = false;
  // The law: K_N, F0, D0, f_max, the step.
  double k, attraction, range, overlap_limit, dt;
  // Friction: k_t / k_n, c_t / c_n, mu, bound on k_n delta (true) or on the normal force.
  double friction_stiffness_ratio, friction_damping_ratio, mu;
  bool elastic_bound;
  // Rolling resistance: K_R, mu_R, c_r / (c_n R_i R_j).
  double rolling_stiffness, rolling_coefficient, rolling_damping;
  // A deforming cell: the pair's flow velocity (strain rate times r) counts in v_n, the cell's share of the
  // pair's move over the step (ContactForces::flow_factor times r) in v_t.
  bool affine;
  double strain_rate_x, strain_rate_y, flow_factor_x, flow_factor_y;
  // The gap up to which a pair interacts (the pair filter's tail reach), for Output::interacting.
  double tail_reach;
};

// The results of eight gathered pairs q .. q + 7 (q a multiple of 8), kept together so that the pair loop
// reaches every field of a pair from one address (it had more arrays than registers to address them):
// which were evaluated here (a bit per lane: a steady contact), and then the pair's partner j, its force
// on j, the tangential force's torques (subtracted from i's and j's), the rolling moment (added to j's and
// subtracted from i's) and the pair vector (for the virial). With Output::interacting, the pairs are any
// listed ones, and a bit per lane tells whether the pair interacts, by the pair filter's own test (else
// the pairs are the pair filter's selection).
struct alignas(64) Results8 {
  double fx[8], fy[8], torque_i[8], torque_j[8], moment[8], rx[8], ry[8];
  std::uint32_t partner[8];
  std::uint8_t steady, interacting;
  // The lanes whose results the pair loop adds as they are: the steady contacts and, from the AVX-512
  // kernel, the open pairs in the attraction's range (a central force, zero torques) and the shell's
  // entries that do not interact (all zero). The pair loop evaluates the others itself.
  std::uint8_t ready;
};

struct Output {
  Results8* results;   // one per eight gathered pairs
  bool interacting = false;
};

// Evaluates the steady contacts among the n gathered pairs (rows[q], list entries pairs[q], images[q]): their forces
// into `out`, their springs and touched stamps updated. Returns how many had their overlap clamped.
// `results` holds n / 8 rounded up.
// Two builds of one kernel (cohesive_contacts_kernel.hpp): cohesive_contacts_avx512.cpp (eight pairs a
// vector) and cohesive_contacts_avx2.cpp (four, each filling half a Results8); only where pair_filter::isa()
// names them.
long evaluate_avx512(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                     std::size_t n, const Output& out);
long evaluate_avx2(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                   std::size_t n, const Output& out);

// Force evaluations that ran the kernel over the shell's slots (Input::dense), counted once per evaluation
// by the pair loop, in this process: for tests, that this path ran.
void note_dense_evaluation();
long dense_evaluations();

}  // namespace grains::cohesive_contacts
