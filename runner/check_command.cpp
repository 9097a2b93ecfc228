#include "check_command.hpp"

#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "output_paths.hpp"
#include "protocols/consolidation_programme.hpp"
#include "resumable_output.hpp"
#include "run_preparation.hpp"

namespace grains {

int check_scene(const std::string& path, const std::vector<std::string>& overrides) {
  const Scene scene = Scene::from_file(path, overrides);
  // All the scene's problems at once: the output's name below reads scene.name or output.file alone, and a bad one
  // was the only problem said.
  scene.validate();
  // What `run` (without --out) would write to; looked at before the simulation is built (resumable_output.hpp).
  const auto [output, source] = hdf5_output_name(scene, "", ".h5");
  const ResumableOutput existing(output, false);
  const PreparedRun r = prepare_run(scene, true);
  if (r.steps) {
    check_hdf5_output_path(output, path, scene, source);
    try {   // a warning: `run` takes --overwrite, or another --out
      existing.refuse_replacing_it(source, "--out", true, RunAboutToStart{scene, *r.steps});
    } catch (const SceneError& e) {
      fmt::print(stderr, "warning: grains run would refuse its output file: {}\n", e.what());
    }
  }
  for (const auto& w : run_warnings(scene, *r.sim)) fmt::print(stderr, "warning: {}\n", w);
  // A scene with a programme is likely meant for `grains consolidate`: its own checks too (a top pressure below
  // the start passed `check` and was refused by `consolidate`), said as a warning, since `run` would take the scene.
  if (!given_programme_keys(scene).empty()) {
    try {
      ProgrammeSettings::from_scene(scene);
      ProgrammeSettings::refuse_floor_above_drag(scene);
    } catch (const SceneError& e) {
      fmt::print(stderr, "warning: grains consolidate would refuse this scene: {}\n", e.what());
    }
  }
  fmt::print("{}", scene.resolved_toml());
  // Derived values, as TOML comments so the output still reads as a scene
  fmt::print("\n# derived: time.dt = {}, {} particles", r.sim->dt(), r.sim->particle_count());
  if (r.steps) fmt::print(", `grains run` takes {} steps", *r.steps);
  // A scene may be meant for `consolidate` or an FMU, which need no run length: said, not refused.
  else fmt::print("; no run length: `grains run` needs time.duration, time.steps or time.free_fall_times");
  fmt::print("\n");
  // What a scene is aimed by but does not set: a user after a given k* had to run a step to read it.
  std::vector<std::string> aims;
  for (const auto& [name, shown] : {std::pair{"contact.k_n", "contact.k_n"}, {"contact.c_n", "contact.c_n"},
                                     {"normalised_stiffness", "k* = k_n / k_g (normalised_stiffness)"},
                                     {"free_fall_time", "t_ff (free_fall_time)"}})
    if (r.sim->has(name))
      aims.push_back(fmt::format("{} = {:.6g}", shown, r.sim->get(name)));
  if (!aims.empty()) fmt::print("# derived: {}\n", fmt::join(aims, ", "));
  // Direct summation's cost grows as N^2: said where the tree is the faster choice (Speed: from about 2000).
  const double n = double(r.sim->particle_count());
  if (scene.boolean("gravity.enabled") && scene.text("gravity.solver") == "direct" && n >= 2000)
    fmt::print("# derived: gravity by direct summation, {:.3g} pairs a step; the tree (gravity.solver = 'tree') is "
               "faster from about 2000 particles\n", n * (n - 1) / 2);
  return 0;
}

}  // namespace grains
