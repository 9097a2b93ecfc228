// Pairs of starting particles that overlap beyond what the contact law takes (a given list or file): such a pair
// flies apart with the energy of its clamped spring, and a coincident pair has no contact direction at all.
// Grids of cells one diameter of each size class wide (the neighbour list's classes; neighbours/size_class_pairs.hpp,
// shared with the cluster analysis): O(N) for any layout, a few grains far larger than the rest among them.
#pragma once
#include <cstddef>

#include "core/box.hpp"
#include "core/particles.hpp"

namespace grains {

struct InitialOverlaps {
  std::size_t deep = 0;                 // pairs with delta > overlap_limit * min(R_i, R_j)
  std::size_t i = 0, j = 0;             // the deepest of them (by delta / min(R_i, R_j); lowest indices on ties)
  double overlap = 0, ratio = 0;        // its delta and delta / min(R_i, R_j)
  bool coincident = false;              // some pair at the same position: the first (lowest indices)
  std::size_t same_i = 0, same_j = 0;
  std::size_t pairs_tested = 0;         // candidate pairs whose distance was measured (the check's cost, for tests)
};

template <int D>
InitialOverlaps find_initial_overlaps(const Particles<D>& P, const Box<D>& box, double overlap_limit);

}  // namespace grains
