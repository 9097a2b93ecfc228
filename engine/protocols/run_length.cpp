#include "protocols/run_length.hpp"

#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace grains {

std::optional<long> run_steps(const Scene& scene, const Simulation& sim) {
  std::vector<std::string> given;
  for (const char* key : {"time.duration", "time.steps", "time.free_fall_times"})
    if (scene.has(key)) given.emplace_back(key);
  if (given.empty()) return std::nullopt;
  if (given.size() > 1)
    scene.fail(given[1], fmt::format("given together with {}: give one of time.duration, time.steps and "
                                     "time.free_fall_times", given[0]));
  if (given[0] == "time.steps") return long(scene.integer("time.steps"));
  double steps = 0;
  if (given[0] == "time.duration") {
    steps = scene.real("time.duration") / sim.dt();
  } else {
    if (!scene.boolean("gravity.enabled"))
      scene.fail("time.free_fall_times", fmt::format("value {} needs the free-fall time of a self-gravitating cloud: set "
                                                     "gravity.enabled = true, or give time.duration",
                                                     scene.real("time.free_fall_times")));
    // One particle (or all at the centre of mass) has R0 = 0: no free-fall time to count in (0 steps, NaN outputs).
    const double free_fall_time = sim.get("free_fall_time");
    if (!(free_fall_time > 0))
      scene.fail("time.free_fall_times", fmt::format("value {} counts in free-fall times t_ff = sqrt(R0^3 / (G M)), but "
                                                     "this cloud of {} particle(s) has none (t_ff = {:.6g}: R0, its largest "
                                                     "distance from the centre of mass, is 0); give time.steps or "
                                                     "time.duration instead", scene.real("time.free_fall_times"),
                                                     sim.particle_count(), free_fall_time));
    steps = scene.real("time.free_fall_times") * free_fall_time / sim.dt();
  }
  // a step count must fit the step counter (and a run of more steps would not end anyway)
  if (!(steps <= Simulation::max_steps))
    scene.fail(given[0], fmt::format("value {} is {:.3g} steps of dt = {:.6g}; at most {:.0e} steps can be run: a shorter "
                                     "run or a larger time step", scene.real(given[0]), steps, sim.dt(), Simulation::max_steps));
  // A positive length that rounds to no step is a slip (a duration in the wrong unit, say): it ran 0 steps unwarned.
  if (std::lround(steps) == 0)
    // The bound in the key's own unit too: time for time.duration, free-fall times for time.free_fall_times.
    scene.fail(given[0], fmt::format("value {} is {:.3g} steps of dt = {:.6g}, which rounds to none: allowed at least half "
                                     "a step, {:.6g} ({:.6g} in time)", scene.real(given[0]), steps, sim.dt(),
                                     0.5 * scene.real(given[0]) / steps, 0.5 * sim.dt()));
  return std::lround(steps);
}

}  // namespace grains
