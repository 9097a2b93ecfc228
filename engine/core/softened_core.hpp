// The densest softened core of a self-gravitating configuration: the largest mass within a distance `reach` of
// one particle's centre, its own mass included. Inside gravity's softening length eps the force on a grain from the
// mass M there, G M m r / (r^2 + eps^2)^{3/2}, tends to G M m r / eps^3: the grain orbits the core with period
// 2 pi sqrt(eps^3 / (G M)), shorter the more grains crowd in. The start-up's orbit rule sees two grains at most;
// once contacts cannot hold grains apart, many may share the core (the aggregation sweep's k* = 10 point ends with
// every grain there), and this measures how many do.
#pragma once
#include <cmath>
#include <cstddef>
#include <numbers>
#include <vector>

#include "core/vec.hpp"

namespace grains {

// The period of the circular orbit of two bodies of total mass M at distance d in the softened potential,
// 2 pi sqrt((d^2 + eps^2)^{3/2} / (G M)); d = 0: a grain inside a core of mass M. The start-up's orbit rule and the
// softened-core check compare their steps: one formula, so that the same pair gives both the same bits (written
// twice, eps^3 and pow(eps^2, 1.5) differed in the last bit, and the pair the start-up rule had warned of was warned
// of again as a core).
inline double softened_orbit_period(double G, double M, double eps, double d = 0) {
  return 2 * std::numbers::pi * std::sqrt(std::pow(d * d + eps * eps, 1.5) / (G * M));
}

// Cores of two grains or more only: a lone grain orbits nothing, and a heavy one must not hide a lighter crowd.
struct SoftenedCore {
  double mass = 0;          // the largest mass within `reach` of a particle's centre, with another there (0: none)
  std::size_t count = 0;    // the particles that make it, the centre included (0: no two within reach)
  std::size_t centre = 0;   // that particle
};

// Hashed cells of edge `reach`, each particle against the 3^D cells around its own: O(N) for particles spread
// wider than `reach`, O(n^2) for n crowded into one cell (as costly as their contacts' pairs then).
template <int D>
SoftenedCore densest_softened_core(const std::vector<Vec<D>>& x, const std::vector<double>& mass, double reach);

extern template SoftenedCore densest_softened_core<2>(const std::vector<Vec<2>>&, const std::vector<double>&, double);
extern template SoftenedCore densest_softened_core<3>(const std::vector<Vec<3>>&, const std::vector<double>&, double);

}  // namespace grains
