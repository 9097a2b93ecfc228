#include "model_variables.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

namespace grains::fmu {
namespace {

// Scene keys that are not FMU parameters: they change which modules and observables exist (so the
// variable table), or belong to the runner (run length, output files) rather than to the model.
bool exposed_scene_key(std::string_view path, ValueKind kind, std::string_view choices) {
  // A text key with choices is an enumeration; a programme's (the preparation) is grains consolidate's, which the
  // FMU does not run.
  const bool enumeration = kind == ValueKind::text && !choices.empty() && !path.starts_with("programme.");
  if (kind != ValueKind::real && kind != ValueKind::integer && kind != ValueKind::boolean && !enumeration) return false;
  if (path == "scene.dimension" || path == "box.periodic" || path == "time.duration" || path == "time.steps" ||
      path == "time.free_fall_times" || path == "analysis.stop_at_aggregation" ||
      path == "analysis.elastic_moduli")   // false removes the moduli outputs: a host could only set it to true
    return false;
  if (path.ends_with(".enabled") || path.starts_with("output.")) return false;
  return true;
}

std::uint64_t fnv1a(std::string_view text, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

}  // namespace

ModelTable describe_model(const Scene& scene, const Simulation& sim) {
  ModelTable t;
  t.particle_count = sim.particle_count();
  t.dimension = sim.dimension();
  const auto& sim_vars = sim.variables();
  auto control_named = [&](std::string_view name) {
    for (std::size_t i = 0; i < sim_vars.size(); ++i)
      if (sim_vars[i].name == name && sim_vars[i].variability != Variability::fixed) return i;
    return no_index;
  };

  // 1. Scene keys the packaged scene sets (a tunable control of the same name takes the key over).
  for (const auto& e : scene_schema()) {
    if (!exposed_scene_key(e.path, e.kind, e.choices) || !scene.has(e.path) || control_named(e.path) != no_index) continue;
    FmuVariable v;
    v.name = std::string(e.path);
    v.role = Role::scene_parameter;
    v.causality = Causality::parameter;
    v.variability = Variability::fixed;
    v.scene_key = v.name;
    v.description = std::string(e.doc);
    v.unit = scene_key_unit(e.path, t.dimension);   // the schema's, as the scene reference gives it
    if (e.kind == ValueKind::text) {
      for (const std::string_view item : choice_list(e)) v.items.emplace_back(item);
      v.type = ValueType::integer;
      v.min = 1, v.max = double(v.items.size());
      v.start = item_value(v, scene.text(e.path));
      v.description += fmt::format(" Values: {}.", item_values(v));
    } else {
      v.type = e.kind == ValueKind::real ? ValueType::real : e.kind == ValueKind::integer ? ValueType::integer : ValueType::boolean;
      v.start = e.kind == ValueKind::real ? scene.real(e.path) : e.kind == ValueKind::integer ? double(scene.integer(e.path))
                                                                                             : double(scene.boolean(e.path));
    }
    if (e.kind == ValueKind::real || e.kind == ValueKind::integer) {
      // FMI's min and max are inclusive: an open bound is declared as the nearest value inside it (the
      // description gives the interval as written).
      const bool real = v.type == ValueType::real;
      if (e.min > -1e307) v.min = !e.min_open ? e.min : real ? std::nextafter(e.min, HUGE_VAL) : std::floor(e.min) + 1;
      if (e.max < 1e307) v.max = !e.max_open ? e.max : real ? std::nextafter(e.max, -HUGE_VAL) : std::ceil(e.max) - 1;
      if (e.min_open || e.max_open) v.description += fmt::format(" Allowed: {}{}, {}{}.", e.min_open ? "(" : "[", e.min,
                                                                 e.max < 1e307 ? fmt::format("{}", e.max) : "inf",
                                                                 e.max_open || e.max >= 1e307 ? ")" : "]");
    }
    if (v.name == "particles.count") {
      v.structural = true;
      t.count_reference = t.variables.size();
    }
    t.variables.push_back(std::move(v));
  }
  // The FMU's own option: HDF5 snapshots through the optional plugin.
  FmuVariable snapshots;
  snapshots.name = "fmu.snapshots_every";
  snapshots.role = Role::snapshot_option;
  snapshots.type = ValueType::integer;
  snapshots.causality = Causality::parameter;
  snapshots.variability = Variability::fixed;
  snapshots.min = 0;
  snapshots.description = "Steps between particle snapshots written to <instance name>.h5 in the working directory "
                          "(the runner's H5MD layout, XDMF beside it), via the HDF5 plugin grains_snapshots.so; 0 = none";
  t.variables.push_back(snapshots);

  auto is_scene_parameter = [&](const std::string& name) {
    for (const auto& v : t.variables)
      if (v.name == name) return true;
    return false;
  };

  // 2. The engine's own variables: derived parameters, controls, then time and the observables.
  for (std::size_t i = 0; i < sim_vars.size(); ++i) {
    const VariableInfo& s = sim_vars[i];
    FmuVariable v;
    v.name = s.name, v.unit = s.unit, v.description = s.description, v.sim_index = i;
    v.causality = s.causality, v.variability = s.variability;
    v.type = s.is_integer ? ValueType::integer : ValueType::real;
    if (s.causality == Causality::output) {
      v.role = s.name == "time" ? Role::independent : Role::output;
      v.type = ValueType::real;
    } else if (s.variability == Variability::fixed && s.causality == Causality::parameter) {
      if (is_scene_parameter(s.name)) continue;   // the scene key already exposes it
      v.role = Role::calculated_parameter;
      v.start = sim.get(i);
    } else {
      v.role = Role::control;
      v.start = sim.get(i);
      v.min = s.min, v.max = s.max;
      if (find_schema_entry(s.name) && scene.has(s.name)) v.scene_key = s.name;
    }
    t.variables.push_back(std::move(v));
  }

  for (auto& v : t.variables)   // integers within what a double holds exactly (exact_integer_limit)
    if (v.type == ValueType::integer)
      v.min = std::max(v.min, -exact_integer_limit), v.max = std::min(v.max, exact_integer_limit);

  // 3. FMI 3 arrays, last, so that the FMI 2 references are the same numbers without them.
  FmuVariable pos;
  pos.name = "particles.position";
  pos.role = Role::particle_array;
  pos.field = ParticleField::position;
  // Rows: the structural parameter where the scene sets the count (the packaged count is only its start value).
  const std::string rows = t.count_reference != no_index ? "particles.count" : fmt::format("{}", t.particle_count);
  pos.description = fmt::format("particle centres, {} x {} (row = particle), wrapped into the box", rows, t.dimension);
  t.variables.push_back(pos);
  FmuVariable rad = pos;
  rad.name = "particles.radius";
  rad.field = ParticleField::radius;
  rad.description = fmt::format("particle radii, {}", rows);
  t.variables.push_back(rad);
  return t;
}

double item_value(const FmuVariable& v, std::string_view item) {
  return double(std::find(v.items.begin(), v.items.end(), item) - v.items.begin() + 1);
}

std::string item_values(const FmuVariable& v) {
  std::vector<std::string> values;
  for (std::size_t k = 0; k < v.items.size(); ++k) values.push_back(fmt::format("{} ({})", k + 1, v.items[k]));
  return fmt::format("{}", fmt::join(values, ", "));
}

std::string instantiation_token(const ModelTable& table) {
  std::uint64_t a = fnv1a("grains-fmu-1"), b = fnv1a("grains-fmu-2");
  for (const auto& v : table.variables) {
    const std::string line = fmt::format("{}|{}|{}|{}|{}|{:.17g};", v.name, int(v.role), int(v.type), int(v.causality),
                                         int(v.variability), v.start);
    a = fnv1a(line, a);
    b = fnv1a(line, b ^ 0x9e3779b97f4a7c15ull);
  }
  return fmt::format("{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}", std::uint32_t(a >> 32), std::uint16_t(a >> 16),
                     std::uint16_t(a), std::uint16_t(b >> 48), b & 0xffffffffffffull);
}

bool same_structure(const ModelTable& a, const ModelTable& b) {
  if (a.variables.size() != b.variables.size() || a.dimension != b.dimension) return false;
  for (std::size_t i = 0; i < a.variables.size(); ++i) {
    const auto &x = a.variables[i], &y = b.variables[i];
    if (x.name != y.name || x.role != y.role || x.type != y.type || x.causality != y.causality ||
        x.variability != y.variability || x.sim_index != y.sim_index)
      return false;
  }
  return true;
}

std::string structure_change(const ModelTable& now, const ModelTable& packaged) {
  std::set<std::string> before, after;
  for (const auto& v : packaged.variables) before.insert(v.name);
  for (const auto& v : now.variables) after.insert(v.name);
  std::vector<std::string> parts;
  const auto list = [&](const char* what, const std::set<std::string>& from, const std::set<std::string>& without) {
    std::vector<std::string> names;
    for (const auto& n : from)
      if (!without.count(n)) names.push_back(n);
    if (names.empty()) return;
    const std::size_t shown = std::min<std::size_t>(names.size(), 6);
    parts.push_back(fmt::format("{} {}{}", what, fmt::join(names.begin(), names.begin() + std::ptrdiff_t(shown), ", "),
                                names.size() > shown ? fmt::format(" and {} more", names.size() - shown) : ""));
  };
  list("without", before, after);
  list("with", after, before);
  if (parts.empty()) return now.dimension != packaged.dimension ? "another dimension" : "its variables in another order or kind";
  return fmt::format("{}", fmt::join(parts, "; "));
}

}  // namespace grains::fmu
