// The output file's writes that `run`, `consolidate` and `resume` share: frames and observable records, its
// start, the new warnings, and the mark of a failed run.
#pragma once
#include <cstddef>
#include <exception>
#include <string>
#include <utility>
#include <vector>

namespace grains {

class H5mdWriter;
class Scene;
class Simulation;
// One particle snapshot / every output variable, at the simulation's current step.
void write_frame(H5mdWriter& out, const Simulation& sim);
// The simulation's outputs as one record; `recorded`: values taken earlier at this step, written instead
// (a stage's contacts kept / lost / gained, counted before the programme marks the next reference).
void write_observables(H5mdWriter& out, const Simulation& sim, const std::vector<std::pair<std::string, double>>& recorded = {});
// The observables write_observables records of `sim`: its outputs but time and step.
std::vector<std::string> observable_names(const Simulation& sim);

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

}  // namespace grains
