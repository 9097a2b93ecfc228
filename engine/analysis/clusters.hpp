// Cluster graph of a particle configuration (physics.md section 8), open box.
// Particles i and j are linked when their centre distance d < R_i + R_j + tol; clusters are the
// connected components (union-find). The pair search (neighbours/size_class_pairs.hpp) uses a uniform cell
// grid of edge 2 R_max + tol, or one per size class where sizes spread over more than a factor 2, so the cost
// is O(N) whatever the spread of the particles and of their sizes.
#pragma once
#include <cstddef>
#include <vector>

#include "core/vec.hpp"

namespace grains {

struct ClusterStats {
  std::size_t count = 0;          // N_c: number of clusters (an isolated particle is a cluster)
  std::vector<int> label;         // cluster of each particle, 0 .. count-1 (in order of first appearance)
  int largest = -1;               // label of the heaviest cluster (lowest label on ties); -1 if no particles
  double largest_fraction = 0;    // f_max: mass of the heaviest cluster / total mass
  std::size_t pairs_tested = 0;   // candidate pairs whose distance was measured (the search's cost, for tests)
};

template <int D>
ClusterStats find_clusters(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const std::vector<double>& mass,
                           double tol);

extern template ClusterStats find_clusters<2>(const std::vector<Vec<2>>&, const std::vector<double>&,
                                              const std::vector<double>&, double);
extern template ClusterStats find_clusters<3>(const std::vector<Vec<3>>&, const std::vector<double>&,
                                              const std::vector<double>&, double);

}  // namespace grains
