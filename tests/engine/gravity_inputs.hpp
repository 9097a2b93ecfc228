// The gravity tests' and benchmarks' inputs (test_gravity.cpp, bench_gravity.cpp): uniform balls of equal
// masses, and the kernel sets this CPU runs.
#pragma once
#include <random>
#include <vector>

#include <catch2/catch.hpp>
#include <fmt/format.h>

#include "core/particles.hpp"
#include "interactions/gravity_direct.hpp"

namespace grains {

// n points uniform in the ball of radius R about the origin (rejection sampling, fixed seed).
inline std::vector<Eigen::Vector3d> uniform_ball(int n, double R, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> p;
  while (int(p.size()) < n) {
    Eigen::Vector3d x(u(rng), u(rng), u(rng));
    if (x.squaredNorm() <= 1) p.push_back(R * x);
  }
  return p;
}

template <int D>
Particles<D> particles_from(const std::vector<Eigen::Vector3d>& p, double mass) {
  Particles<D> P;
  P.resize(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) {
    P.position[i] = p[i].head<D>();
    P.set_mass_and_radius(i, mass, 0.01);
  }
  return P;
}

// The kernel sets (gravity_direct::Isa) this CPU runs, portable first; a set it lacks is named in a warning.
inline std::vector<gravity_direct::Isa> runnable_isas() {
  using gravity_direct::Isa;
  std::vector<Isa> out;
  for (Isa isa : {Isa::portable, Isa::avx2, Isa::avx512}) {
    if (gravity_direct::supported(isa)) out.push_back(isa);
    else WARN(fmt::format("the CPU lacks {}: its gravity kernels are not tested here", gravity_direct::isa_name(isa)));
  }
  return out;
}

}  // namespace grains
