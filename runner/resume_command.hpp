#pragma once
#include <string>

#include "io/h5md_checkpoint.hpp"

namespace grains {

class H5mdWriter;
class Scene;
class Simulation;

// `grains resume`: continues the run or programme in `path` (its output file) from the newest checkpoint
// there, with the scene stored in it; the records after that step are replaced. Returns the exit code.
int resume_run(const std::string& path, bool quiet);

// For both resumes: the scene stored with a checkpoint, and the simulation built from it restored to the
// checkpoint (the one before it if that state does not fit) after checking it has the run's particles.
Scene stored_scene(const std::string& path, const RunCheckpoint& cp);
void restore_checkpoint(Simulation& sim, const std::string& path, RunCheckpoint& cp);

// The gravity kernels this process uses, as checkpoints record them.
std::string gravity_kernels();
// Where a self-gravitating run goes on with other gravity kernels than its checkpoint's (another processor, or
// GRAINS_GRAVITY_ISA), said on stderr and in the file's warnings: from the checkpoint's step its last bits differ
// from the unbroken run's.
void warn_of_other_gravity_kernels(const std::string& path, const Scene& scene, const RunCheckpoint& cp, H5mdWriter& out);

}  // namespace grains
