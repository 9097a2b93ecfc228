#include "io/scene_units.hpp"

#include <cstdlib>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

namespace grains {

std::string si_unit(const Dimension& d, int scene_dimension) {
  const int m = d.length_power(scene_dimension), kg = d.mass, s = d.time;
  if (kg == 1 && s == -2) {   // the named units the outputs use: energy, force, force per length
    if (m == 2) return "J";
    if (m == 1) return "N";
    if (m == 0) return "N/m";
  }
  std::vector<std::string> above, below;
  for (const auto& [symbol, power] : {std::pair{"kg", kg}, std::pair{"m", m}, std::pair{"s", s}}) {
    if (power == 0) continue;
    const int p = std::abs(power);
    (power > 0 ? above : below).push_back(p == 1 ? symbol : fmt::format("{}^{}", symbol, p));
  }
  if (above.empty() && below.empty()) return "";
  std::string unit = above.empty() ? "1" : fmt::format("{}", fmt::join(above, " "));
  if (below.size() == 1) unit += "/" + below[0];
  if (below.size() > 1) unit += fmt::format("/({})", fmt::join(below, " "));
  return unit;
}

}  // namespace grains
