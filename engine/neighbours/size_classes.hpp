// Size classes of the grid searches (the neighbour list; the pair search of neighbours/size_class_pairs.hpp that the
// starting-overlap check and the cluster analysis share):
// class c holds radii in (r_max / 2^(c+1), r_max / 2^c], class 0 the largest; at most eight classes, the last
// also holding every smaller radius. Each class gets a grid sized by its own largest grain, so that a few large
// grains do not put a bed of small ones in every cell.
#pragma once
#include <algorithm>
#include <cmath>

namespace grains {

struct SizeClasses {
  static constexpr int most = 8;
  double rmax = 1;
  int count = 1;

  SizeClasses(double largest, double smallest)
      : rmax(largest), count(std::clamp(int(std::ceil(std::log2(largest / smallest) - 1e-12)), 1, most)) {}

  int of(double radius) const {
    return count == 1 ? 0 : std::clamp(int(std::floor(std::log2(rmax / radius))), 0, count - 1);
  }
};

}  // namespace grains
