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

inline std::string listed_scene(int dimension, const ListedParticles& p, const ContactUnderTest& c) {
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
[box]
periodic = false
[contact]
restitution = {}
duration = {}
calibration = "{}"
overlap_limit = 1.0
[time]
steps_per_contact = {}
[run]
threads = 1
)", dimension, rows(p.positions), rows(p.velocities), fmt::join(p.diameters, ", "),
                     p.masses.empty() ? "" : fmt::format("masses = [{}]", fmt::join(p.masses, ", ")), c.restitution,
                     c.duration, c.calibration, c.steps_per_contact);
}
