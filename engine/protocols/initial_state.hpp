// Initial particles and box from a scene: layout, sizes, masses, velocities.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/box.hpp"
#include "core/particles.hpp"
#include "io/scene.hpp"

namespace grains {

template <int D>
struct InitialState {
  Particles<D> particles;
  Box<D> box;
  std::vector<std::string> warnings;   // for the simulation's warnings (e.g. deeply overlapping given particles)
};

template <int D>
InitialState<D> make_initial_state(const Scene& scene);

// The file the particles are read from (particles.layout = "file"; a relative path lies in the scene's folder).
std::optional<std::filesystem::path> particle_file(const Scene& scene);

}  // namespace grains
