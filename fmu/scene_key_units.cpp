#include "scene_key_units.hpp"

#include <map>

namespace grains::fmu {

std::string scene_key_unit(std::string_view path, int dimension) {
  // A disk's density is per area, its stress a force per length (the engine's stress outputs say N/m in 2D).
  if (path == "particles.density") return dimension == 2 ? "kg/m^2" : "kg/m^3";
  static const std::map<std::string_view, std::string_view> units = {
      {"particles.diameter", "m"}, {"particles.diameter_min", "m"}, {"particles.diameter_max", "m"},
      {"particles.mass", "kg"}, {"particles.kinetic_energy", "J"},
      {"contact.duration", "s"},
      {"adhesion.force", "N"}, {"adhesion.range", "m"}, {"adhesion.stiffness", "N/m"},
      {"rolling.coefficient", "m"},
      {"drag.rate", "1/s"},
      {"cell.ramp_duration", "s"}, {"cell.force_unit", "N"}, {"cell.mass", "kg"},
      {"programme.first_compression_time", "s"},
      {"time.dt", "s"}, {"time.duration", "s"},
      {"neighbours.skin", "m"}, {"neighbours.shell", "m"},
  };
  const auto it = units.find(path);
  return it == units.end() ? "" : std::string(it->second);
}

}  // namespace grains::fmu
