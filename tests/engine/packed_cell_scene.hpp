// The scene text of a cohesionless polydisperse packing (diameters uniform in [a/2, a], friction 0.3)
// under pressure control, single-threaded: shared by the barostat and consolidation programme tests.
#pragma once
#include <string>

#include <fmt/format.h>

#include "polydisperse_particles.hpp"

// `extra`: further [cell] keys or TOML tables (e.g. [programme]).
inline std::string packed_cell_scene(int dimension, int count, double pressure, const std::string& extra = "") {
  return polydisperse_particles(dimension, count, dimension == 2 ? 0.4 : 0.25, 3) + fmt::format(R"(
[contact]
restitution = 0.1
duration = 0.05
[friction]
coefficient = 0.3
[cell]
enabled = true
force_unit = 0
pressure = {}
{}
[run]
threads = 1
)", pressure, extra);
}
