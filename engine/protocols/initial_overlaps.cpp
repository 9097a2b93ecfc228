#include "protocols/initial_overlaps.hpp"

#include <algorithm>
#include <utility>
#include <vector>

#include "neighbours/size_class_pairs.hpp"

namespace grains {

template <int D>
InitialOverlaps find_initial_overlaps(const Particles<D>& P, const Box<D>& box, double overlap_limit) {
  InitialOverlaps found;
  const std::size_t N = P.size();
  if (N < 2) return found;
  // The size classes' grids, cells one of each class's largest diameters wide (neighbours/size_class_pairs.hpp): with
  // one class, the single grid it was. One grid sized by the largest grain put a whole bed of small grains in the
  // cells around a large one: 159,000 disks and one of 40 diameters took 12 s (0.2 s without it).
  auto test = [&](std::size_t i, std::size_t j) {
    ++found.pairs_tested;
    const double d = box.minimum_image(P.position[j] - P.position[i]).norm();
    const double rmin_ij = std::min(P.radius[i], P.radius[j]);
    const double overlap = P.radius[i] + P.radius[j] - d;
    const std::size_t lo = std::min(i, j), hi = std::max(i, j);
    if (d == 0 && (!found.coincident || std::pair(lo, hi) < std::pair(found.same_i, found.same_j)))
      found.coincident = true, found.same_i = lo, found.same_j = hi;
    if (!(overlap > overlap_limit * rmin_ij)) return;
    ++found.deep;
    // Equally deep pairs: the lowest indices, as testing every pair in index order names them (the classes' grids
    // visit a large grain's pairs with smaller ones at the large grain, out of that order).
    const double ratio = overlap / rmin_ij;
    if (ratio > found.ratio || (ratio > 0 && ratio == found.ratio && std::pair(lo, hi) < std::pair(found.i, found.j)))
      found.i = lo, found.j = hi, found.overlap = overlap, found.ratio = ratio;
  };
  SizeClassPairs<D>(P.position, P.radius, 0.0, box).for_each_pair(test);
  return found;
}

template InitialOverlaps find_initial_overlaps<2>(const Particles<2>&, const Box<2>&, double);
template InitialOverlaps find_initial_overlaps<3>(const Particles<3>&, const Box<3>&, double);

}  // namespace grains
