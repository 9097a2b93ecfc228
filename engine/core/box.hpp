// The simulation box: per axis a lower corner, a length and whether it is periodic.
#pragma once
#include <array>
#include <cmath>

#include "core/vec.hpp"

namespace grains {

template <int D>
struct Box {
  Vec<D> lower = Vec<D>::Zero();
  Vec<D> length = Vec<D>::Ones();
  std::array<bool, D> periodic{};

  bool any_periodic() const {
    for (bool p : periodic) if (p) return true;
    return false;
  }
  double volume() const { return length.prod(); }

  // Map a position into the primary cell on periodic axes.
  Vec<D> wrap(Vec<D> x) const {
    for (int a = 0; a < D; ++a)
      if (periodic[a]) x[a] -= length[a] * std::floor((x[a] - lower[a]) / length[a]);
    return x;
  }
  // Shortest periodic image of a separation vector.
  Vec<D> minimum_image(Vec<D> r) const {
    for (int a = 0; a < D; ++a)
      if (periodic[a]) r[a] -= length[a] * std::round(r[a] / length[a]);
    return r;
  }
};

}  // namespace grains
