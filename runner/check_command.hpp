#pragma once
#include <string>
#include <vector>

namespace grains {

// `grains check`: the same checks as `run` without running (the simulation is built, the run length
// resolved, warnings printed); prints the resolved scene and the derived time step and length.
int check_scene(const std::string& path, const std::vector<std::string>& overrides);

}  // namespace grains
