// The scene text of a few listed particles in an open box with the consolidation contact law
// (physics.md section 6) at the paper's Table I values: a = 1, F0 = 1, K_N = 1e5, D0 = 1e-3, e_N = 0.015.
#pragma once
#include <string>

#include "head_on_scene.hpp"

// `extra`: further TOML sections; `particle_keys`: further keys of [particles] (e.g. angular_velocities).
inline std::string adhesive_scene(int dimension, const ListedParticles& p, const std::string& extra = "",
                                  const std::string& particle_keys = "") {
  auto rows = [](const std::vector<std::vector<double>>& m) {
    std::vector<std::string> r;
    for (const auto& row : m) r.push_back(fmt::format("[{}]", fmt::join(row, ", ")));
    return fmt::format("[{}]", fmt::join(r, ", "));
  };
  return fmt::format(R"(
[scene]
dimension = {}
[particles]
layout = "list"
positions = {}
velocity = "list"
velocities = {}
diameters = [{}]
{}
{}
[box]
periodic = false
[adhesion]
enabled = true
[run]
threads = 1
{}
)", dimension, rows(p.positions), rows(p.velocities), fmt::join(p.diameters, ", "),
                     p.masses.empty() ? "" : fmt::format("masses = [{}]", fmt::join(p.masses, ", ")), particle_keys, extra);
}
