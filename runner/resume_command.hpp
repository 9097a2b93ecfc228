#pragma once
#include <string>

#include "io/h5md_checkpoint.hpp"

namespace grains {

class Scene;
class Simulation;

// `grains resume`: continues the run or programme in `path` (its output file) from the newest checkpoint
// there, with the scene stored in it; the records after that step are replaced. Returns the exit code.
int resume_run(const std::string& path, bool quiet);

// For both resumes: the scene stored with a checkpoint, and the simulation built from it restored to the
// checkpoint (the one before it if that state does not fit) after checking it has the run's particles.
Scene stored_scene(const std::string& path, const RunCheckpoint& cp);
void restore_checkpoint(Simulation& sim, const std::string& path, RunCheckpoint& cp);

}  // namespace grains
