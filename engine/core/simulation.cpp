// The seam's own code: a simulation of the scene's dimension (core/simulation_impl.hpp), and variables by name.
#include "core/simulation.hpp"

#include <fmt/format.h>

#include "core/simulation_impl.hpp"
#include "io/scene.hpp"

namespace grains {

bool Simulation::has(const std::string& name) const {
  for (const auto& v : variables())
    if (v.name == name) return true;
  return false;
}

std::size_t Simulation::index_of(const std::string& name) const {
  const auto& v = variables();
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i].name == name) return i;
  throw SimulationError(fmt::format("unknown variable '{}'", name));
}

std::unique_ptr<Simulation> Simulation::create(const Scene& scene, const PreparationProgress& progress) {
  scene.validate();
  if (scene.integer("scene.dimension") == 2) return std::make_unique<SimulationImpl<2>>(scene, progress);
  return std::make_unique<SimulationImpl<3>>(scene, progress);
}

}  // namespace grains
