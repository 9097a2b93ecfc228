// One interaction of a contact network, linearised about the present state: what the stiffness
// matrix of the elastic moduli (analysis/elastic_moduli.hpp) is assembled from.
#pragma once
#include <cstdint>

#include "core/vec.hpp"

namespace grains {

template <int D>
struct ElasticSpring {
  std::uint32_t i = 0, j = 0;
  Vec<D> branch = Vec<D>::Zero();   // r_ij = x_j - x_i (nearest periodic image)
  double arm_i = 0, arm_j = 0;      // centre-to-contact-point distances (R - delta/2, adding up to |r_ij|)
  double normal = 0;        // -dF_N/dh: K_N in contact (past the overlap clamp too), -F0/D0 for a distant bond (0 <= h < D0)
  double tangential = 0;    // K_T (0: no tangential spring, e.g. a distant bond)
  double rolling = 0;       // K_R (0: none)
  // The static forces, for the Reuss estimate: F_N (compressive positive; the overlap clamped as the law clamps
  // it), |F_T|, |Gamma|, and the contact stiffness K_N that weights them (also for a distant bond, as in the
  // paper's Z2).
  double normal_force = 0, tangential_force = 0, rolling_moment = 0;
  double contact_stiffness = 0;
  // The bounds |F_T| and |Gamma| slide at: mu F_N^e and mu_R F_N^e, F_N^e = K_N delta the elastic part
  // (physics.md sections 4-6); 0 where there is no such spring.
  double tangential_bound = 0, rolling_bound = 0;
};

}  // namespace grains
