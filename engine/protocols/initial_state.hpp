// Initial particles and box from a scene: layout, sizes, masses, velocities.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/particles.hpp"
#include "io/scene.hpp"
#include "protocols/preparation_progress.hpp"

namespace grains {

template <int D>
struct InitialState {
  Particles<D> particles;
  Box<D> box;
  std::vector<std::string> warnings;   // for the simulation's warnings (e.g. deeply overlapping given particles)
};

// `progress`, where given, hears how a random insertion goes.
template <int D>
InitialState<D> make_initial_state(const Scene& scene, const PreparationProgress& progress = {});

// The grain that sets the reduced units (physics.md section 9: a = the largest diameter of the size
// distribution, m = the mass of a grain of diameter a). Where the scene draws or sets the sizes, a is the
// distribution's own (particles.diameter_max, particles.diameter), not the largest drawn, which falls short
// of it by a random amount; listed or file particles give the largest of theirs. m follows the density
// unless the scene gives the masses, then it is the largest grain's.
struct UnitGrain {
  double diameter, mass;
};
template <int D>
UnitGrain unit_grain(const Scene& scene, const Particles<D>& particles);

// The file the particles are read from (particles.layout = "file"; a relative path lies in the scene's folder).
std::optional<std::filesystem::path> particle_file(const Scene& scene);

}  // namespace grains
