#include "analysis/fractal_dimension.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace grains {

template <int D>
double fractal_dimension(const std::vector<Vec<D>>& x, const std::vector<double>& radius, const std::vector<double>& mass,
                         int samples) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::size_t N = x.size();
  if (N < 2 || samples < 2) return nan;
  Vec<D> c = Vec<D>::Zero();
  double M = 0, mean_d = 0;
  for (std::size_t i = 0; i < N; ++i) c += mass[i] * x[i], M += mass[i], mean_d += 2 * radius[i];
  c /= M, mean_d /= double(N);
  std::vector<double> r(N);
  for (std::size_t i = 0; i < N; ++i) r[i] = (x[i] - c).norm();
  std::sort(r.begin(), r.end());
  const double r_lo = 2 * mean_d;
  const std::size_t k90 = std::size_t(std::ceil(0.9 * double(N)));   // particles the upper radius must hold
  const double r_hi = r[std::max<std::size_t>(k90, 1) - 1];
  if (!(r_hi > r_lo)) return nan;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int k = 0; k < samples; ++k) {
    const double rk = r_lo * std::pow(r_hi / r_lo, double(k) / (samples - 1));
    const double n = double(std::upper_bound(r.begin(), r.end(), rk * (1 + 1e-12)) - r.begin());
    const double lx = std::log(rk), ly = std::log(std::max(n, 1.0));
    sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
  }
  const double n = samples;
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

template double fractal_dimension<2>(const std::vector<Vec<2>>&, const std::vector<double>&, const std::vector<double>&, int);
template double fractal_dimension<3>(const std::vector<Vec<3>>&, const std::vector<double>&, const std::vector<double>&, int);

}  // namespace grains
