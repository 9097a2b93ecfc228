// Mass-radius fractal dimension of a set of particles (physics.md section 8), e.g. the largest cluster.
// N(r) = number of particles whose centre lies within r of the set's centre of mass (mass-weighted);
// D_f = least-squares slope of log N against log r over `samples` log-spaced radii from
// r_lo = 2 * (mean diameter) to r_hi = the smallest radius holding 90 % of the particles.
// Returns NaN when r_hi <= r_lo (too few particles for a scaling range).
#pragma once
#include <vector>

#include "core/vec.hpp"

namespace grains {

template <int D>
double fractal_dimension(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const std::vector<double>& mass,
                         int samples = 20);

extern template double fractal_dimension<2>(const std::vector<Vec<2>>&, const std::vector<double>&, const std::vector<double>&, int);
extern template double fractal_dimension<3>(const std::vector<Vec<3>>&, const std::vector<double>&, const std::vector<double>&, int);

}  // namespace grains
