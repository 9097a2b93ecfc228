// The table of named variables through which everything outside the engine talks to a Simulation.
// The runner, the FMU wrappers (and their modelDescription.xml) and the tests read the same table.
#pragma once
#include <limits>
#include <string>
#include <vector>

namespace grains {

enum class Causality { parameter, input, output };
// discrete: an input that matters only where its value changes (a marker, a switch); hosts hold it, never interpolate it.
enum class Variability { fixed, tunable, continuous, discrete };

struct VariableInfo {
  std::string name;          // dotted scene path for parameters ("contact.restitution"), plain name otherwise
  std::string unit;          // "" when dimensionless or in the scene's own units
  Causality causality;
  Variability variability;
  std::string description;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool is_integer = false;   // exported as Integer; values are still exchanged as double
};

inline const char* to_string(Causality c) {
  switch (c) { case Causality::parameter: return "parameter"; case Causality::input: return "input"; default: return "output"; }
}
inline const char* to_string(Variability v) {
  switch (v) { case Variability::fixed: return "fixed"; case Variability::tunable: return "tunable";
    case Variability::discrete: return "discrete"; default: return "continuous"; }
}

}  // namespace grains
