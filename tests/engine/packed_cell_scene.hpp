// The scene text of a cohesionless polydisperse packing (diameters uniform in [a/2, a], friction 0.3)
// under pressure control, single-threaded: shared by the barostat and consolidation programme tests.
#pragma once
#include <string>

#include <fmt/format.h>

// `extra`: further [cell] keys or TOML tables (e.g. [programme]).
inline std::string packed_cell_scene(int dimension, int count, double pressure, const std::string& extra = "") {
  return fmt::format(R"(
[scene]
dimension = {}
[particles]
layout = "random"
count = {}
size_distribution = "uniform"
diameter_min = 0.5
diameter_max = 1.0
solid_fraction = {}
seed = 3
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
)", dimension, count, dimension == 2 ? 0.4 : 0.25, pressure, extra);
}
