// `grains run`: a scene stepped to its run length, its outputs written as it goes; and the resume of such a run.
#pragma once
#include <string>
#include <vector>

namespace grains {

class Scene;
struct RunCheckpoint;

struct RunOptions {
  std::string scene, output;
  std::vector<std::string> overrides;
  bool quiet = false;
  bool overwrite = false;   // replace an output that holds a run `grains resume` could continue (resumable_output.hpp)
};

// Validates the scene completely before touching the output file; returns the process exit code.
int run_scene(const RunOptions& options);

// `grains resume` of a `grains run` output (resume_command.hpp), at its checkpoint `cp`, with its stored `scene`.
int resume_plain_run(const std::string& path, const Scene& scene, RunCheckpoint& cp, bool quiet);

}  // namespace grains
