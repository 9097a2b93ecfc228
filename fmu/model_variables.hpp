// The FMU's variable table: one list, built from a scene and the Simulation made from it, that both
// the modelDescription.xml generator and the FMI wrapper read. A variable's value reference is its
// index in this list, so the XML and the binary cannot disagree about references, types or causality.
#pragma once
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "core/variables.hpp"

namespace grains {
class Scene;
class Simulation;
}

namespace grains::fmu {

enum class Role {
  scene_parameter,       // a scene key, set before initialization (the Simulation is built from the scene)
  calculated_parameter,  // derived by the engine from the scene (k_n, dt...)
  control,               // input or tunable parameter: Simulation::set while stepping
  snapshot_option,       // fmu.snapshots_every: the FMU's own HDF5 snapshot output (0 = off)
  independent,           // time
  output,                // an observable: Simulation::get
  particle_array,        // FMI 3 only: per-particle values (positions, radii)
};
enum class ValueType { real, integer, boolean };
enum class ParticleField { position, radius };

constexpr std::size_t no_index = std::numeric_limits<std::size_t>::max();
// Values travel through the FMU as doubles: integer variables are declared and checked within the range a
// double holds exactly (2^53), so that no FMI 3 Int64 / UInt64 is rounded on its way in or out.
constexpr double exact_integer_limit = 9007199254740992.0;

struct FmuVariable {
  std::string name, unit, description;
  Role role = Role::output;
  ValueType type = ValueType::real;
  Causality causality = Causality::output;
  Variability variability = Variability::continuous;
  double start = 0;   // parameters and controls: the value in the packaged scene
  double min = -std::numeric_limits<double>::infinity(), max = std::numeric_limits<double>::infinity();
  std::string scene_key;          // scene parameters, and controls that are also scene keys
  std::size_t sim_index = no_index;   // index in Simulation::variables()
  ParticleField field = ParticleField::position;
  bool structural = false;        // FMI 3: particles.count as the structural parameter sizing the arrays
  // A text scene key's choices (gravity.solver: direct, tree): an enumeration, type integer, value k = items[k - 1].
  std::vector<std::string> items;
};

// An enumeration's value of `item` (its position among the items, from 1).
double item_value(const FmuVariable& v, std::string_view item);
// An enumeration's values as the host reads them: "1 (direct), 2 (tree)".
std::string item_values(const FmuVariable& v);

struct ModelTable {
  std::vector<FmuVariable> variables;   // value reference = index
  std::size_t count_reference = no_index;   // the structural particle-count parameter, if the scene sets the count
  std::size_t particle_count = 0;
  int dimension = 3;
};

// The table for a scene (the packaged one, or one with overrides: the same keys, other values).
ModelTable describe_model(const Scene& scene, const Simulation& sim);

// A fingerprint of the table (names, types, causalities, start values), formatted as a GUID: the
// instantiation token of the generated modelDescription.xml, checked again at instantiation.
std::string instantiation_token(const ModelTable& table);

// Same structure (names, types, causality, references): a parameter override must not change it.
bool same_structure(const ModelTable& a, const ModelTable& b);
// What differs when they are not: the variables `now` lacks and has beyond `packaged`, by name.
std::string structure_change(const ModelTable& now, const ModelTable& packaged);

}  // namespace grains::fmu
