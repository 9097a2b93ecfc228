// What `run` checks before it opens the output file, and the warnings it starts with: shared with `check`,
// which runs the same checks without running.
#pragma once
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/simulation.hpp"

namespace grains {

class Scene;

// The scene, the simulation built from it, and the run's length (none when the scene gives none: a programme's scene).
struct PreparedRun {
  std::unique_ptr<Simulation> sim;
  std::optional<long> steps;
  bool stop_at_aggregation;
};

// `show_progress`: a status line while a long preparation (random insertion) runs.
PreparedRun prepare_run(const Scene& scene, bool show_progress);

// The scene's [programme] keys, which only `grains consolidate` reads.
std::vector<std::string> given_programme_keys(const Scene& scene);

// The start-up warnings of `run` (and `check`): the simulation's, the programme's keys, which `grains
// consolidate` reads and a plain run does not (a scene shared with it; the converse of its run-length warning),
// and the elastic moduli's cost at every record.
std::vector<std::string> run_warnings(const Scene& scene, const Simulation& sim);

}  // namespace grains
