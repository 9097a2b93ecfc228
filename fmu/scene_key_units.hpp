// The unit an FMU declares for a scene key it exposes as a parameter, in SI as its outputs declare theirs ("" for a
// pure number or a key not listed); a scene written in other units gives the value in its own (README, Units).
#pragma once
#include <string>
#include <string_view>

namespace grains::fmu {

std::string scene_key_unit(std::string_view path, int dimension);

}  // namespace grains::fmu
