// How many of a simulation's warnings contain a text: the warning tests count those of one check.
#pragma once
#include <algorithm>
#include <string>

#include "core/simulation.hpp"

inline long warnings_of(const grains::Simulation& sim, const std::string& text) {
  return std::count_if(sim.warnings().begin(), sim.warnings().end(),
                       [&](const std::string& w) { return w.find(text) != std::string::npos; });
}
