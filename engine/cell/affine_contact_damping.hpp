// The damping the contacts' dashpots exert on the cell's own motion. Particle velocities are stored
// relative to the affine flow, so the pair loop's dashpots never see the relative normal velocity
// the cell strain imposes on a contact, sum_b (dL_b/dt / L_b) r^b n^b. Its force -c_n v_n n, put
// into the cell equation through the virial, is (keeping the diagonal) a drag -eta_a dL_a/dt with
//   eta_a = sum over contacts of c_n (r^a n^a)^2 / L_a^2 = c_n sum (r^a)^4 / (d^2 L_a^2).
// Without it a jammed cell breathes undamped; loose samples have few contacts and stay unthrottled.
#pragma once
#include "core/system.hpp"

namespace grains {

template <int D>
Vec<D> affine_contact_damping(const System<D>& s, double normal_damping) {
  const auto& P = s.particles;
  const auto& nl = s.neighbours;
  Vec<D> sum = Vec<D>::Zero();
  for (std::size_t i = 0; i + 1 < nl.start.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const auto j = nl.partner[k];
      const Vec<D> r = P.position[j] + nl.shift[nl.image[k]] - P.position[i];
      const double reach = P.radius[i] + P.radius[j], d2 = r.squaredNorm();
      if (d2 >= reach * reach) continue;
      sum += r.array().square().square().matrix() / d2;
    }
  return normal_damping * sum.cwiseQuotient(s.box.length.cwiseProduct(s.box.length));
}

}  // namespace grains
