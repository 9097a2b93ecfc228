// The simulation box: per axis a lower corner, a length and whether it is periodic.
#pragma once
#include <array>
#include <cmath>

#include "core/image.hpp"
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

  // Map a position into the primary cell on periodic axes; with `image`, add the cell lengths taken off to it.
  Vec<D> wrap(Vec<D> x, Image<D>* image = nullptr) const {
    for (int a = 0; a < D; ++a)
      if (periodic[a]) {
        const double cells = std::floor((x[a] - lower[a]) / length[a]);
        x[a] -= length[a] * cells;
        if (image) (*image)[a] += static_cast<std::int64_t>(cells);
      }
    return x;
  }
  // How far a position may lie from the cell on a periodic axis, in cell lengths: wrap adds the cells taken off
  // to an integer image count, which a particle 1e19 cells off overflowed (found by fuzzing).
  static constexpr double max_cells_off = 1e6;
  // How many cell lengths x lies from the cell's lower corner on axis a (0 on an open axis).
  double cells_off(const Vec<D>& x, int a) const { return periodic[a] ? std::abs(x[a] - lower[a]) / length[a] : 0.0; }
  // Shortest periodic image of a separation vector.
  Vec<D> minimum_image(Vec<D> r) const {
    for (int a = 0; a < D; ++a)
      if (periodic[a]) r[a] -= length[a] * std::round(r[a] / length[a]);
    return r;
  }
};

}  // namespace grains
