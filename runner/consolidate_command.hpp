#pragma once
#include <string>
#include <vector>

namespace grains {

struct ConsolidateOptions {
  std::string scene, output, table;
  std::vector<std::string> overrides;
  bool quiet = false;
};

// Runs the scene's consolidation programme (preparation, loading, unloading); one H5MD observable
// record, one snapshot and one table row per stage. Returns the process exit code.
int consolidate_scene(const ConsolidateOptions& options);

}  // namespace grains
