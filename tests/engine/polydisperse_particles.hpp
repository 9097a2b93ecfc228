// The [scene] and [particles] sections of the papers' polydisperse grains, shared by the tests' packing
// scenes: `count` disks (2D) or spheres with diameters uniform in [a/2, a] (a = 1), placed at random at
// `solid_fraction`. `particle_keys`: further [particles] keys (density, velocities).
#pragma once
#include <string>

#include <fmt/format.h>

inline std::string polydisperse_particles(int dimension, int count, double solid_fraction, int seed,
                                          const std::string& particle_keys = "") {
  return fmt::format(R"(
[scene]
dimension = {}
[particles]
layout = "random"
count = {}
size_distribution = "uniform"
diameter_min = 0.5
diameter_max = 1.0
solid_fraction = {}
seed = {}
{})", dimension, count, solid_fraction, seed, particle_keys);
}
