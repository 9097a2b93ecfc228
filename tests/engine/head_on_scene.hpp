// The scene text of a few particles with explicit positions, velocities, sizes and masses in an open
// box, with the contact law under test: shared by the collision tests.
#pragma once
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

struct ListedParticles {
  std::vector<std::vector<double>> positions, velocities;
  std::vector<double> diameters, masses;   // masses empty: from the default density
};

struct ContactUnderTest {
  double restitution, duration, steps_per_contact;
  std::string calibration = "global";
};

// Two unit-mass particles of diameter 1 on the x axis approaching head-on at relative speed 1;
// their surfaces touch after `gap` time units.
inline ListedParticles head_on_pair(int dimension, double gap) {
  ListedParticles p;
  p.positions = {std::vector<double>(dimension, 0.0), std::vector<double>(dimension, 0.0)};
  p.positions[1][0] = 1 + gap;
  p.velocities = {std::vector<double>(dimension, 0.0), std::vector<double>(dimension, 0.0)};
  p.velocities[0][0] = 0.5, p.velocities[1][0] = -0.5;
  p.diameters = {1.0, 1.0};
  p.masses = {1.0, 1.0};
  return p;
}

// The [scene], [particles] and [box] sections of listed particles, single-threaded, in an open box unless
// `box_keys` says otherwise. `particle_keys`: further keys of [particles] (e.g. angular_velocities).
inline std::string listed_particles_toml(int dimension, const ListedParticles& p, const std::string& particle_keys = "",
                                         const std::string& box_keys = "periodic = false") {
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
{}
[run]
threads = 1
)", dimension, rows(p.positions), rows(p.velocities), fmt::join(p.diameters, ", "),
                     p.masses.empty() ? "" : fmt::format("masses = [{}]", fmt::join(p.masses, ", ")), particle_keys,
                     box_keys);
}

inline std::string listed_scene(int dimension, const ListedParticles& p, const ContactUnderTest& c) {
  return listed_particles_toml(dimension, p) + fmt::format(R"(
[contact]
restitution = {}
duration = {}
calibration = "{}"
overlap_limit = 1.0
[time]
steps_per_contact = {}
)", c.restitution, c.duration, c.calibration, c.steps_per_contact);
}
