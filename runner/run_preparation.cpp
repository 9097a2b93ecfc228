#include "run_preparation.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "progress.hpp"
#include "protocols/run_length.hpp"

namespace grains {

PreparedRun prepare_run(const Scene& scene, bool show_progress) {
  scene.validate();
  PreparedRun r{create_simulation(scene, show_progress), std::nullopt, scene.boolean("analysis.stop_at_aggregation")};
  r.steps = run_steps(scene, *r.sim);
  if (r.stop_at_aggregation && !scene.boolean("gravity.enabled"))
    scene.fail("analysis.stop_at_aggregation", "value true needs the aggregation analysis of a self-gravitating cloud: "
                                               "set gravity.enabled = true, or stop_at_aggregation = false");
  return r;
}

std::vector<std::string> given_programme_keys(const Scene& scene) {
  std::vector<std::string> programme;
  for (const auto& e : scene_schema())
    if (e.path.starts_with("programme.") && scene.has(e.path)) programme.push_back(std::string(e.path));
  return programme;
}

std::vector<std::string> run_warnings(const Scene& scene, const Simulation& sim) {
  std::vector<std::string> warnings = sim.warnings();
  const std::vector<std::string> programme = given_programme_keys(scene);
  if (!programme.empty())
    warnings.push_back(fmt::format("{} {} not used by grains run, which steps the scene as it is (the cell at cell.pressure): "
                                   "the programme is grains consolidate's", fmt::join(programme, ", "),
                                   programme.size() > 1 ? "are" : "is"));
  // The moduli are meant for equilibrated stages (grains consolidate computes them once a stage); a plain run
  // records them with every observable, and one factorisation of a dense packing costs hundreds of steps' time.
  if (scene.boolean("analysis.elastic_moduli"))
    warnings.push_back(fmt::format(
        "analysis.elastic_moduli = true: grains run factorises the contact network's stiffness at every observables "
        "record (output.observables_every = {}; measured 11-52 ms for 1444 dense disks and 0.32-2.1 s for 1000 dense spheres, "
        "against about 30 us a step): set it false, or raise output.observables_every, unless this run needs the moduli",
        scene.integer("output.observables_every")));
  return warnings;
}

}  // namespace grains
