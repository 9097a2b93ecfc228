#pragma once
#include <string>
#include <vector>

namespace grains {

struct ConsolidateOptions {
  std::string scene, output, table;
  std::vector<std::string> overrides;
  bool quiet = false;
  bool overwrite = false;   // replace an output that holds a programme `grains resume` could continue
};

// Runs the scene's consolidation programme (preparation, loading, unloading); one H5MD observable
// record, one snapshot and one table row per stage. Returns the process exit code.
int consolidate_scene(const ConsolidateOptions& options);

class Scene;
struct RunCheckpoint;
// `grains resume` of a programme: continues from the stage after the checkpoint's (written at the end of every
// stage), the table and the HDF5 file cut back to the stages finished before; `scene` is the one stored in the file.
int resume_consolidation(const std::string& path, const Scene& scene, RunCheckpoint& checkpoint, bool quiet);

}  // namespace grains
