// Connected components of the interaction graph (contacts and distant attractive bonds): a type-2
// sample has aggregated once this is 1 (physics.md section 9). Periodic images come for free, since
// the interactions already carry them.
#pragma once
#include <numeric>
#include <vector>

#include "analysis/contact_network.hpp"

namespace grains {

inline std::size_t count_bonded_clusters(std::size_t particle_count, const std::vector<NetworkInteraction>& interactions) {
  std::vector<std::uint32_t> parent(particle_count);
  std::iota(parent.begin(), parent.end(), 0u);
  auto root = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];   // path halving
    return i;
  };
  std::size_t clusters = particle_count;
  for (const auto& c : interactions) {
    const auto a = root(c.i), b = root(c.j);
    if (a != b) parent[std::max(a, b)] = std::min(a, b), --clusters;
  }
  return clusters;
}

}  // namespace grains
