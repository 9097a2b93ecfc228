// The scene text of a few listed particles in an open box with the consolidation contact law
// (physics.md section 6) at the paper's Table I values: a = 1, F0 = 1, K_N = 1e5, D0 = 1e-3, e_N = 0.015.
#pragma once
#include <string>

#include "head_on_scene.hpp"

// `extra`: further TOML sections; `particle_keys`: further keys of [particles] (e.g. angular_velocities).
inline std::string adhesive_scene(int dimension, const ListedParticles& p, const std::string& extra = "",
                                  const std::string& particle_keys = "") {
  return listed_particles_toml(dimension, p, particle_keys) + "[adhesion]\nenabled = true\n" + extra + "\n";
}
