// Two scenes the contact tests share. `extra`: further TOML tables appended to the scene.
// - compressed_packing: 300 cohesive disks (adhesion, friction, rolling resistance with its dashpot) of
//   diameters 0.5-1 at solid fraction 0.36 with some heat, in a periodic cell that is pressure-controlled
//   (affine = true) or fixed.
// - hot_spheres: a dense hot gas of 500 spheres (diameters 0.6-1, e = 0.6, a tight overlap clamp) with
//   Coulomb friction mu (0: none) and a tangential dashpot, in a fixed or a pressure-controlled cell.
#pragma once
#include <string>

#include <fmt/format.h>

#include "io/scene.hpp"
#include "polydisperse_particles.hpp"

namespace grains {

inline Scene compressed_packing(int threads, double rolling, bool affine, const std::string& extra = "") {
  const std::string particles =
      polydisperse_particles(2, 300, 0.36, 5, "density = 1.273239544735163\nvelocity = \"gaussian\"\nkinetic_energy = 0.02\n");
  return Scene::from_string(particles + fmt::format(R"(
[box]
periodic = true
[contact]
overlap_limit = 0.5
[adhesion]
enabled = true
[friction]
coefficient = 0.5
[rolling]
coefficient = {}
damping_ratio = 0.01
[cell]
enabled = true
active = {}
pressure = 0.05
[run]
threads = {}
{}
)", rolling, affine, threads, extra), "batched");
}

inline Scene hot_spheres(int threads, bool cell, double mu, const std::string& extra = "") {
  return Scene::from_string(fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "random"
count = 500
size_distribution = "uniform"
diameter_min = 0.6
diameter_max = 1.0
solid_fraction = 0.3
velocity = "gaussian"
kinetic_energy = 1.5
seed = 9
[box]
periodic = true
[contact]
restitution = 0.6
duration = 0.05
overlap_limit = 0.05
[friction]
coefficient = {}
stiffness_ratio = 0.2857142857142857
damping_ratio = 0.5
[cell]
enabled = {}
{}[run]
threads = {}
{}
)", mu, cell, cell ? "force_unit = 0\npressure = 1e-3\n" : "", threads, extra), "batched-linear");
}

}  // namespace grains
