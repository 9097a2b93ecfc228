// An explicit drag on the cell standing for the contacts' dashpots (cell.contact_damping, default 0): the
// normal force -c_n v_n n of the relative velocity the cell strain imposes on a contact, sum_b (dL_b/dt / L_b)
// r^b n^b, put into the cell equation through the virial, is (keeping the diagonal) a drag -eta_a dL_a/dt with
//   eta_a = sum over contacts of c_n (r^a n^a)^2 / L_a^2 = c_n sum (r^a)^4 / (d^2 L_a^2).
// An older approximation: the pair loop's dashpots now see that velocity themselves (the affine flow term in
// contact_forces.hpp and the batched kernels), so a factor above 0 counts the contacts' damping twice, on
// top of assuming that every contact strains affinely (tenuous cohesive networks buckle instead).
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
