// modelDescription.xml for FMI 2.0 and FMI 3.0, written from the FMU variable table
// (model_variables.hpp), plus the human-readable variable list shipped as documentation.
#pragma once
#include <string>

#include "model_variables.hpp"

namespace grains::fmu {

struct ModelInfo {
  std::string name;          // the scene name ("aggregation")
  std::string identifier;    // modelIdentifier = shared library name ("grains_aggregation")
  std::string description;   // scene.description
  std::string version;       // grains version
  double stop_time = 1;      // DefaultExperiment: the scene's duration
  double step_size = 0.1;    // DefaultExperiment: 100 internal steps
};

std::string fmi2_model_description(const ModelTable& table, const ModelInfo& info);
std::string fmi3_model_description(const ModelTable& table, const ModelInfo& info);
std::string documentation_html(const ModelTable& table, const ModelInfo& info);

}  // namespace grains::fmu
