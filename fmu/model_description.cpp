#include "model_description.hpp"

#include <climits>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "instance.hpp"
#include "io/xml_escape.hpp"

namespace grains::fmu {
namespace {

std::string number(double x) { return fmt::format("{}", x); }

std::string causality_name(const FmuVariable& v, int fmi) {
  switch (v.role) {
    case Role::scene_parameter: return fmi == 3 && v.structural ? "structuralParameter" : "parameter";
    case Role::snapshot_option: return "parameter";
    case Role::calculated_parameter: return "calculatedParameter";
    case Role::independent: return "independent";
    case Role::control: return v.causality == Causality::input ? "input" : "parameter";
    default: return "output";
  }
}
std::string variability_name(const FmuVariable& v) {
  if (v.role == Role::scene_parameter || v.role == Role::calculated_parameter || v.role == Role::snapshot_option) return "fixed";
  if (v.role == Role::control && v.causality != Causality::input) return "tunable";
  // FMI: integers are never continuous; a discrete real (network.mark) is held by hosts, not interpolated
  if (v.role == Role::control) return v.type == ValueType::real && v.variability != Variability::discrete ? "continuous" : "discrete";
  return "continuous";
}
bool has_start(const FmuVariable& v) {
  return v.role == Role::scene_parameter || v.role == Role::control || v.role == Role::snapshot_option;
}

std::string start_text(const FmuVariable& v) {
  if (v.type == ValueType::boolean) return v.start != 0 ? "true" : "false";
  if (v.type == ValueType::integer) return fmt::format("{}", static_cast<long long>(v.start));
  return number(v.start);
}

// min / max attributes; integer bounds are clipped to the FMI type's range.
std::string range_attributes(const FmuVariable& v, double lowest, double highest) {
  std::string out;
  auto integer = v.type == ValueType::integer;
  if (std::isfinite(v.min) && v.min > lowest)
    out += integer ? fmt::format(" min=\"{}\"", static_cast<long long>(v.min)) : fmt::format(" min=\"{}\"", number(v.min));
  if (std::isfinite(v.max))
    out += integer ? fmt::format(" max=\"{}\"", static_cast<long long>(std::min(v.max, highest)))
                   : fmt::format(" max=\"{}\"", number(v.max));
  return out;
}

std::string unit_definitions(const ModelTable& t) {
  std::set<std::string> units;
  for (const auto& v : t.variables)
    if (!v.unit.empty()) units.insert(v.unit);
  if (units.empty()) return "";
  std::string out = "  <UnitDefinitions>\n";
  for (const auto& u : units) out += fmt::format("    <Unit name=\"{}\"/>\n", xml_escape(u));
  return out + "  </UnitDefinitions>\n";
}

// Each enumeration's items as a type named after its scene key (FMI 2: SimpleType; FMI 3: EnumerationType).
std::string type_definitions(const ModelTable& t, int fmi) {
  std::string types;
  for (const auto& v : t.variables) {
    if (v.items.empty()) continue;
    std::string items;
    for (std::size_t k = 0; k < v.items.size(); ++k)
      items += fmt::format("{}<Item name=\"{}\" value=\"{}\"/>\n", fmi == 2 ? "        " : "      ", xml_escape(v.items[k]), k + 1);
    types += fmi == 2 ? fmt::format("    <SimpleType name=\"{}\">\n      <Enumeration>\n{}      </Enumeration>\n    </SimpleType>\n",
                                    xml_escape(v.name), items)
                      : fmt::format("    <EnumerationType name=\"{}\">\n{}    </EnumerationType>\n", xml_escape(v.name), items);
  }
  return types.empty() ? "" : "  <TypeDefinitions>\n" + types + "  </TypeDefinitions>\n";
}

std::string log_categories_xml() {
  std::string out = "  <LogCategories>\n";
  for (const auto& [name, doc] : log_categories()) out += fmt::format("    <Category name=\"{}\" description=\"{}\"/>\n", name, xml_escape(doc));
  return out + "  </LogCategories>\n";
}

std::string default_experiment(const ModelInfo& info) {
  return fmt::format("  <DefaultExperiment startTime=\"0\" stopTime=\"{}\" stepSize=\"{}\"/>\n", number(info.stop_time),
                     number(info.step_size));
}

bool is_initial_unknown(const FmuVariable& v) {
  return v.role == Role::output || v.role == Role::calculated_parameter || v.role == Role::particle_array;
}

}  // namespace

std::string fmi2_model_description(const ModelTable& t, const ModelInfo& info) {
  std::string out = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"{}\" guid=\"{}\" description=\"{}\" generationTool=\"grains {}\"\n"
      "  variableNamingConvention=\"flat\" numberOfEventIndicators=\"0\">\n"
      "  <CoSimulation modelIdentifier=\"{}\" canHandleVariableCommunicationStepSize=\"true\" canInterpolateInputs=\"false\"\n"
      "    maxOutputDerivativeOrder=\"0\" canRunAsynchronuously=\"false\" canBeInstantiatedOnlyOncePerProcess=\"false\"\n"
      "    canNotUseMemoryManagementFunctions=\"true\" canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"true\"\n"
      "    providesDirectionalDerivative=\"false\"/>\n",
      xml_escape(info.name), instantiation_token(t), xml_escape(info.description), xml_escape(info.version), xml_escape(info.identifier));
  out += unit_definitions(t) + type_definitions(t, 2) + log_categories_xml() + default_experiment(info);
  out += "  <ModelVariables>\n";
  std::vector<std::size_t> outputs, initial_unknowns;
  std::size_t index = 0;   // FMI 2 refers to variables by 1-based position in this list
  for (std::size_t ref = 0; ref < t.variables.size(); ++ref) {
    const FmuVariable& v = t.variables[ref];
    if (v.role == Role::particle_array) continue;   // FMI 2 has no arrays
    ++index;
    if (v.role == Role::output) outputs.push_back(index);
    if (is_initial_unknown(v)) initial_unknowns.push_back(index);
    std::string attributes = fmt::format("name=\"{}\" valueReference=\"{}\" description=\"{}\" causality=\"{}\" variability=\"{}\"",
                                         xml_escape(v.name), ref, xml_escape(v.description), causality_name(v, 2), variability_name(v));
    if (v.role == Role::calculated_parameter) attributes += " initial=\"calculated\"";
    if (has_start(v) && v.causality != Causality::input) attributes += " initial=\"exact\"";
    std::string element;
    const std::string unit = v.unit.empty() ? "" : fmt::format(" unit=\"{}\"", xml_escape(v.unit));
    const std::string start = has_start(v) ? fmt::format(" start=\"{}\"", start_text(v)) : "";
    if (v.type == ValueType::real) element = fmt::format("<Real{}{}{}/>", start, range_attributes(v, -INFINITY, INFINITY), unit);
    else if (!v.items.empty()) element = fmt::format("<Enumeration declaredType=\"{}\"{}/>", xml_escape(v.name), start);
    else if (v.type == ValueType::integer) element = fmt::format("<Integer{}{}/>", start, range_attributes(v, INT_MIN, INT_MAX));
    else element = fmt::format("<Boolean{}/>", start);
    out += fmt::format("    <ScalarVariable {}>\n      {}\n    </ScalarVariable>\n", attributes, element);
  }
  out += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
  for (auto i : outputs) out += fmt::format("      <Unknown index=\"{}\"/>\n", i);
  out += "    </Outputs>\n    <InitialUnknowns>\n";
  for (auto i : initial_unknowns) out += fmt::format("      <Unknown index=\"{}\"/>\n", i);
  out += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
  return out;
}

std::string fmi3_model_description(const ModelTable& t, const ModelInfo& info) {
  std::string out = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"{}\" instantiationToken=\"{}\" description=\"{}\"\n"
      "  generationTool=\"grains {}\" variableNamingConvention=\"flat\">\n"
      "  <CoSimulation modelIdentifier=\"{}\" canHandleVariableCommunicationStepSize=\"true\" canGetAndSetFMUState=\"true\"\n"
      "    canSerializeFMUState=\"true\" canBeInstantiatedOnlyOncePerProcess=\"false\" providesDirectionalDerivatives=\"false\"\n"
      "    providesAdjointDerivatives=\"false\" hasEventMode=\"false\" providesIntermediateUpdate=\"false\"\n"
      "    canReturnEarlyAfterIntermediateUpdate=\"false\" providesEvaluateDiscreteStates=\"false\" maxOutputDerivativeOrder=\"0\"/>\n",
      xml_escape(info.name), instantiation_token(t), xml_escape(info.description), xml_escape(info.version), xml_escape(info.identifier));
  out += unit_definitions(t) + type_definitions(t, 3) + log_categories_xml() + default_experiment(info);
  out += "  <ModelVariables>\n";
  std::vector<std::size_t> outputs, initial_unknowns;
  for (std::size_t ref = 0; ref < t.variables.size(); ++ref) {
    const FmuVariable& v = t.variables[ref];
    if (v.role == Role::output || v.role == Role::particle_array) outputs.push_back(ref);
    if (is_initial_unknown(v)) initial_unknowns.push_back(ref);
    const char* type = v.type == ValueType::boolean ? "Boolean"
                       : v.type == ValueType::real  ? "Float64"
                       : !v.items.empty()           ? "Enumeration"
                       : v.structural               ? "UInt64"
                                                    : "Int64";
    std::string attributes = fmt::format("name=\"{}\" valueReference=\"{}\" description=\"{}\" causality=\"{}\" variability=\"{}\"",
                                         xml_escape(v.name), ref, xml_escape(v.description), causality_name(v, 3), variability_name(v));
    if (v.role == Role::calculated_parameter) attributes += " initial=\"calculated\"";
    if (has_start(v)) attributes += fmt::format(" start=\"{}\"", start_text(v));
    if (v.type == ValueType::real) {
      attributes += range_attributes(v, -INFINITY, INFINITY);
      if (!v.unit.empty()) attributes += fmt::format(" unit=\"{}\"", xml_escape(v.unit));
    } else if (!v.items.empty()) {
      attributes += fmt::format(" declaredType=\"{}\"", xml_escape(v.name));
    } else if (v.type == ValueType::integer) {
      attributes += range_attributes(v, v.structural ? 0.0 : double(LLONG_MIN), v.structural ? 1.8e19 : 9.2e18);
    }
    if (v.role != Role::particle_array) {
      out += fmt::format("    <{} {}/>\n", type, attributes);
      continue;
    }
    // Arrays: rows = particles, sized by the structural parameter when the scene sets the count.
    std::string rows = t.count_reference != no_index ? fmt::format("<Dimension valueReference=\"{}\"/>", t.count_reference)
                                                     : fmt::format("<Dimension start=\"{}\"/>", t.particle_count);
    if (v.field == ParticleField::position) rows += fmt::format("<Dimension start=\"{}\"/>", t.dimension);
    out += fmt::format("    <{} {}>{}</{}>\n", type, attributes, rows, type);
  }
  out += "  </ModelVariables>\n  <ModelStructure>\n";
  for (auto r : outputs) out += fmt::format("    <Output valueReference=\"{}\"/>\n", r);
  for (auto r : initial_unknowns) out += fmt::format("    <InitialUnknown valueReference=\"{}\"/>\n", r);
  out += "  </ModelStructure>\n</fmiModelDescription>\n";
  return out;
}

std::string documentation_html(const ModelTable& t, const ModelInfo& info) {
  std::string out = fmt::format(
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>{0}</title></head><body>\n<h1>grains FMU: {0}</h1>\n<p>{1}</p>\n"
      "<p>Co-simulation FMU (FMI 2.0 and 3.0) of the grains DEM engine. Parameters are scene keys (see the scene "
      "reference); the scene itself is <code>resources/scene.toml</code>. Internal steps use the scene's dt: a "
      "communication step h of k whole dt (within 1e-9 dt or the rounding of the host's clock) takes k steps of dt, "
      "the runner's; any other h takes ceil(h / dt) equal steps landing on t + h (an h below 1e-9 dt is carried "
      "over). Inputs are held over a step. A host whose clock counts whole nanoseconds (libcosim) gets whole steps "
      "only where dt is a whole number of nanoseconds.</p>\n"
      "<table border=\"1\"><tr><th>reference</th><th>name</th><th>causality</th><th>variability</th><th>start</th><th>unit</th>"
      "<th>meaning</th></tr>\n",
      xml_escape(info.name), xml_escape(info.description));
  for (std::size_t ref = 0; ref < t.variables.size(); ++ref) {
    const FmuVariable& v = t.variables[ref];
    out += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", ref, xml_escape(v.name),
                       causality_name(v, 3) + (v.role == Role::particle_array ? " (FMI 3 array)" : ""), variability_name(v),
                       !has_start(v)      ? std::string()
                       : v.items.empty() ? start_text(v)
                                         : fmt::format("{} ({})", start_text(v), xml_escape(v.items[std::size_t(v.start) - 1])),
                       xml_escape(v.unit), xml_escape(v.description));
  }
  return out + "</table>\n</body></html>\n";
}

}  // namespace grains::fmu
