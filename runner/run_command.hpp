#pragma once
#include <string>
#include <vector>

namespace grains {

struct RunOptions {
  std::string scene, output;
  std::vector<std::string> overrides;
  bool quiet = false;
};

// Validates the scene completely before touching the output file; returns the process exit code.
int run_scene(const RunOptions& options);

}  // namespace grains
