#pragma once
// How long a run lasts: exactly one of the scene's time.duration, time.steps and time.free_fall_times
// (a multiple of the free-fall time t_ff of physics.md section 8, gravity scenes), turned into steps of
// the simulation's dt. Shared by the runner and the FMU's default stop time.
#include <optional>

#include "core/simulation.hpp"
#include "io/scene.hpp"

namespace grains {

// Steps of the run the scene asks for; nullopt when it gives none of the three keys. A scene that
// gives two, or free_fall_times without self-gravity, fails naming the keys.
std::optional<long> run_steps(const Scene& scene, const Simulation& sim);

}  // namespace grains
