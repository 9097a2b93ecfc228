// The steady contacts of frictionless spheres, eight at a time (AVX-512): the linear spring-dashpot law
// with one global (k_n, c_n) (physics.md section 2) for the contacts that already touched at the last
// force evaluation, as the gas scene has them. Those take no onset corrections; the pair loop
// (contact_forces.hpp) evaluates a contact's first step itself and adds every result in list order. Each
// lane does the portable code's operations in the same order (LinearContactLaw::force with its release
// charge), with correctly rounded roots and divisions and no multiply-add contraction, so the forces are
// bit-identical to it.
#pragma once
#include <cstddef>
#include <cstdint>

#include "core/vec.hpp"

namespace grains::linear_contacts_avx512 {

struct Input {
  const double *position, *radius, *mass, *velocity_predicted;   // positions and velocities as x, y, z triples
  const std::uint32_t* partner;                                    // each list entry's j
  const Vec<3>* shift;                                             // the 27 image shifts
  std::uint32_t* touched;                                          // per entry: the evaluation it last touched at
  std::uint32_t evaluation;
  double k, c, overlap_limit, dt;                                  // the law, the step
  bool affine;                                                     // a deforming cell: the flow counts in v_n
  double strain_rate[3];
};

// Per gathered pair q: whether it was evaluated here (a bit per pair), its force on j and its pair vector.
struct Output {
  std::uint8_t* steady;
  double *fx, *fy, *fz, *rx, *ry, *rz;
};

// Evaluates the steady contacts among the n gathered pairs (rows[q], list entries pairs[q], images[q]).
// Returns how many had their overlap clamped. Output arrays hold n rounded up to a multiple of 8.
long evaluate(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
              std::size_t n, const Output& out);

}  // namespace grains::linear_contacts_avx512
