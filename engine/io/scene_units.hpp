// The physical dimension of a scene key, from which its SI unit follows. The schema (io/scene.hpp) gives one for
// every number: the scene reference shows the unit, the FMUs declare it for the keys they expose, and the unit
// tests (tests/engine/test_unit_scaling.cpp) convert scenes to other units by it.
#pragma once
#include <string>

namespace grains {

// L^length M^mass T^time (L^D)^space. `space` counts powers of the space's own measure, a volume for spheres and an
// area for disks: a density is per volume in 3D and per area in 2D (README, Units).
struct Dimension {
  int length = 0, mass = 0, time = 0, space = 0;

  bool operator==(const Dimension&) const = default;

  int length_power(int scene_dimension) const { return length + space * scene_dimension; }
};

// The SI unit as the engine's outputs write theirs ("m", "N/m", "kg/m^3", "m^3/(kg s^2)"); "" for a pure number.
std::string si_unit(const Dimension& d, int scene_dimension);

}  // namespace grains
