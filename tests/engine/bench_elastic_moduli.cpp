// Benchmark, hidden from the suite (run: grains_tests "[.moduli-bench]"): the cost of one elastic-moduli
// evaluation (assembly, sparse LDL^T, three refinements) for disordered frictional networks in 2D and 3D.
#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <random>

#include <fmt/format.h>

#include "analysis/elastic_moduli.hpp"

using namespace grains;

namespace {

// n^D grains on a jittered simple cubic / square lattice of unit spacing with diameters in [0.9, 1.25]:
// overlapping pairs are frictional contacts (z about 4 in 2D, 6 in 3D).
template <int D>
std::vector<ElasticSpring<D>> jittered_network(int n, std::size_t& grains, double& volume) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> jitter(-0.1, 0.1), size(0.45, 0.625);
  std::vector<Vec<D>> x;
  std::vector<double> radius;
  const int N = int(std::pow(n, D));
  for (int k = 0; k < N; ++k) {
    Vec<D> p;
    for (int a = 0, m = k; a < D; ++a, m /= n) p[a] = (m % n) + 0.5 + jitter(rng);
    x.push_back(p), radius.push_back(size(rng));
  }
  grains = x.size(), volume = std::pow(double(n), D);
  std::vector<ElasticSpring<D>> out;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) {
      Vec<D> r = x[j] - x[i];
      for (int a = 0; a < D; ++a) r[a] -= n * std::round(r[a] / n);
      const double gap = r.norm() - radius[i] - radius[j];
      if (gap >= 0) continue;
      ElasticSpring<D> s;
      s.i = std::uint32_t(i), s.j = std::uint32_t(j), s.branch = r;
      s.arm_i = radius[i] + 0.5 * gap, s.arm_j = radius[j] + 0.5 * gap;
      s.normal = s.contact_stiffness = 1e5, s.tangential = 1e5, s.rolling = 1e1;
      s.normal_force = 1e5 * -gap;
      out.push_back(s);
    }
  return out;
}

template <int D>
void time_moduli(int n) {
  std::size_t grains = 0;
  double volume = 0;
  const auto springs = jittered_network<D>(n, grains, volume);
  elastic_moduli<D>(grains, volume, springs);   // warm-up
  const int reps = 3;
  ElasticModuli<D> e;
  const auto t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < reps; ++k) e = elastic_moduli<D>(grains, volume, springs);
  const double ms = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps * 1e3;
  WARN(fmt::format("{}D, {} grains, {} springs (z = {:.2f}): {:.1f} ms per evaluation, B = {:.4g}, G = {:.4g}", D, grains,
                   springs.size(), 2.0 * double(springs.size()) / double(grains), ms, e.bulk, e.shear));
  CHECK(e.bulk > 0);
}

}  // namespace

TEST_CASE("elastic moduli cost", "[.moduli-bench]") {
  time_moduli<2>(38);   // 1444 disks, the paper's size
  time_moduli<2>(71);   // 5041 disks
  time_moduli<3>(10);   // 1000 spheres
  time_moduli<3>(12);   // 1728 spheres
}
