#pragma once
#include <exception>
#include <string>
#include <utility>
#include <vector>

namespace grains {

class H5mdWriter;
class Simulation;
// One particle snapshot / every output variable, at the simulation's current step.
void write_frame(H5mdWriter& out, const Simulation& sim);
// The simulation's outputs as one record; `recorded`: values taken earlier at this step, written instead
// (a stage's contacts kept / lost / gained, counted before the programme marks the next reference).
void write_observables(H5mdWriter& out, const Simulation& sim, const std::vector<std::pair<std::string, double>>& recorded = {});
// The observables write_observables records of `sim`: its outputs but time and step.
std::vector<std::string> observable_names(const Simulation& sim);

class Scene;
// A new output file's start, shared by `run` and `consolidate`: the scene's folder (where `grains resume` finds
// its relative files), the warnings (also on stderr), the first frame and records (`recorded`: values that stand in
// for the simulation's own, as write_observables).
void begin_output(H5mdWriter& out, const Scene& scene, const Simulation& sim, const std::vector<std::string>& warnings,
                  const std::vector<std::pair<std::string, double>>& recorded = {});
// A run or programme stopped by an error: its file says so ("failed after step N: ..."), not "running" as a killed
// run's does, and `grains resume` refuses it.
void mark_failed(H5mdWriter& out, const Simulation& sim, const std::exception& error);
// Writes (and prints) the warnings the simulation raised since the first `written` ones: the run's own, e.g.
// the energy check's, raised while the observables are computed, or a programme's target pressure's.
void write_new_warnings(H5mdWriter& out, const Simulation& sim, std::size_t& written);

struct RunOptions {
  std::string scene, output;
  std::vector<std::string> overrides;
  bool quiet = false;
  bool overwrite = false;   // replace an output that holds a run `grains resume` could continue (resumable_output.hpp)
};

// Validates the scene completely before touching the output file; returns the process exit code.
int run_scene(const RunOptions& options);

// `grains resume` of a `grains run` output (resume_command.hpp), at its checkpoint `cp`, with its stored `scene`.
class Scene;
struct RunCheckpoint;
int resume_plain_run(const std::string& path, const Scene& scene, RunCheckpoint& cp, bool quiet);

// `grains check`: the same checks as `run` without running (the simulation is built, the run length
// resolved, warnings printed); prints the resolved scene and the derived time step and length.
int check_scene(const std::string& path, const std::vector<std::string>& overrides);

}  // namespace grains
