// Eight equal particles on a lattice at solid fraction 0.1 with defaults for the rest (no gravity, no
// analysis): the scene in which an optional observable or log must be absent, or a key refused.
#pragma once
#include <string>

// `contact`: the keys of its [contact] table.
inline std::string plain_lattice_scene(const std::string& contact = "duration = 0.01") {
  return R"(
[particles]
layout = "lattice"
count = 8
solid_fraction = 0.1
[contact]
)" + contact + "\n";
}
