#include "run_output.hpp"

#include <algorithm>
#include <new>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/h5md_frame_view.hpp"
#include "io/h5md_writer.hpp"
#include "io/output_error.hpp"
#include "io/scene.hpp"

namespace grains {

void write_frame(H5mdWriter& out, const Simulation& sim) {
  const ParticleView p = sim.particles();
  const BoxView b = sim.box();
  const H5mdFrame f = frame_view(sim.step_count(), sim.time(), p, b);
  out.write_frame(f);
}

namespace {
// An output recorded as an observable: time and step are the records' own columns.
bool recorded_as_observable(const VariableInfo& v) {
  return v.causality == Causality::output && v.name != "time" && v.name != "step";
}
}  // namespace

void write_observables(H5mdWriter& out, const Simulation& sim, const std::vector<std::pair<std::string, double>>& recorded) {
  const auto& vars = sim.variables();
  for (std::size_t i = 0; i < vars.size(); ++i) {
    if (!recorded_as_observable(vars[i])) continue;
    const auto given = std::find_if(recorded.begin(), recorded.end(), [&](const auto& r) { return r.first == vars[i].name; });
    out.write_observable(vars[i].name, sim.step_count(), sim.time(), given != recorded.end() ? given->second : sim.get(i));
  }
}

std::vector<std::string> observable_names(const Simulation& sim) {
  std::vector<std::string> names;
  for (const auto& v : sim.variables())
    if (recorded_as_observable(v)) names.push_back(v.name);
  return names;
}

void begin_output(H5mdWriter& out, const Scene& scene, const Simulation& sim, const std::vector<std::string>& warnings,
                  const std::vector<std::pair<std::string, double>>& recorded) {
  out.set_attribute("scene_directory", scene.directory().string());
  out.set_attribute("status", "running");   // replaced at the end: a file left with it was killed
  try {   // a first frame that cannot be made (out of memory) is a failure, not a kill
    std::size_t from_simulation = sim.warnings().size();   // those `warnings` holds
    for (const auto& w : warnings) {
      out.write_warning(w);
      fmt::print(stderr, "warning: {}\n", w);
    }
    write_frame(out, sim);
    write_observables(out, sim, recorded);
    // The initial state's observables run the checks too (an overlap already past the pass-through limit): their
    // warnings go to the file and stderr here, not counted as written unseen.
    write_new_warnings(out, sim, from_simulation);
  } catch (const std::exception& e) {
    mark_failed(out, sim, e);
    throw;
  }
}

void mark_failed(H5mdWriter& out, const Simulation& sim, const std::exception& error) {
  // An output error (a full disk) leaves the run resumable from its last checkpoint once the cause is gone.
  const char* what = dynamic_cast<const OutputError*>(&error) ? "stopped by an output error" : "failed";
  try {
    // "after": the steps completed (an error inside a step names that step itself: "after step 1: step 2: ...").
    const bool memory = dynamic_cast<const std::bad_alloc*>(&error);   // its what() is "std::bad_alloc"
    out.set_attribute("status", fmt::format("{} after step {}: {}", what, sim.step_count(), memory ? "out of memory" : error.what()));
    out.flush();
  } catch (const std::exception&) {   // the file may not take it (the same full disk): "running" stays, resumable
  }
}

void write_new_warnings(H5mdWriter& out, const Simulation& sim, std::size_t& written) {
  const auto& w = sim.warnings();
  for (; written < w.size(); ++written) {
    out.write_warning(w[written]);
    fmt::print(stderr, "warning: {}\n", w[written]);
  }
}

}  // namespace grains
