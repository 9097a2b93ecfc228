#include "run_command.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <utility>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/simulation.hpp"
#include "interactions/pair_filter.hpp"
#include "io/h5md_checkpoint.hpp"
#include "io/h5md_frame_view.hpp"
#include "io/h5md_writer.hpp"
#include "io/output_error.hpp"
#include "io/scene.hpp"
#include "output_paths.hpp"
#include "resumable_output.hpp"
#include "resume_command.hpp"
#include "progress.hpp"
#include "protocols/consolidation_programme.hpp"
#include "protocols/run_length.hpp"
#include "stop_cadence.hpp"
#include "stop_signal.hpp"

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
    // warnings were counted as written, and went neither to the file nor to stderr (an outside review, 2026-12-07).
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

namespace {

// What `run` checks before it opens the output file, shared with `check`: the scene, the simulation
// built from it, and the run's length (none when the scene gives none: a programme's scene).
struct PreparedRun {
  std::unique_ptr<Simulation> sim;
  std::optional<long> steps;
  bool stop_at_aggregation;
};

// `show_progress`: a status line while a long preparation (random insertion) runs.
PreparedRun prepare_run(const Scene& scene, bool show_progress) {
  scene.validate();
  PreparedRun r{create_simulation(scene, show_progress), std::nullopt, scene.boolean("analysis.stop_at_aggregation")};
  r.steps = run_steps(scene, *r.sim);
  if (r.stop_at_aggregation && !scene.boolean("gravity.enabled"))
    scene.fail("analysis.stop_at_aggregation", "value true needs the aggregation analysis of a self-gravitating cloud: "
                                               "set gravity.enabled = true, or stop_at_aggregation = false");
  return r;
}

// The scene's [programme] keys, which only `grains consolidate` reads.
std::vector<std::string> given_programme_keys(const Scene& scene) {
  std::vector<std::string> programme;
  for (const auto& e : scene_schema())
    if (e.path.starts_with("programme.") && scene.has(e.path)) programme.push_back(std::string(e.path));
  return programme;
}

// The start-up warnings of `run` (and `check`): the simulation's, the programme's keys, which `grains
// consolidate` reads and a plain run does not (a scene shared with it; the converse of its run-length warning),
// and the elastic moduli's cost at every record.
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

}  // namespace

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
      existing.refuse_replacing_it(source, "--out");
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

void write_new_warnings(H5mdWriter& out, const Simulation& sim, std::size_t& written) {
  const auto& w = sim.warnings();
  for (; written < w.size(); ++written) {
    out.write_warning(w[written]);
    fmt::print(stderr, "warning: {}\n", w[written]);
  }
}

namespace {

// The run's loop from the simulation's present step to `steps`, then its end and summary: shared by `run`
// and `resume` (which comes in at a checkpoint's step with the wall time spent before it).
int continue_run(const Scene& scene, Simulation& sim, H5mdWriter& out, long steps, bool stop_at_aggregation, bool quiet,
                 double earlier_seconds) {
  const double initial_energy = sim.get("kinetic_energy");
  // The file holds the start-up warnings (begin_output, or the run being resumed), and a resumed simulation
  // knows whether its energy check has warned (saved state): only later ones are written.
  std::size_t warnings_written = sim.warnings().size();
  const long obs_every = scene.integer("output.observables_every");
  const long snap_every = scene.integer("output.snapshots_every");
  const long checkpoint_every = scene.integer("output.checkpoint_every");
  // The loop stops at every step some output is due at (the aggregation check too, to stop at the check that sees it).
  std::vector<long> intervals{obs_every};
  if (snap_every > 0) intervals.push_back(snap_every);
  if (checkpoint_every > 0) intervals.push_back(checkpoint_every);
  if (stop_at_aggregation) intervals.push_back(scene.integer("analysis.every"));
  auto next_stop = [&](long done) {
    long next = steps;
    for (long e : intervals) next = std::min(next, (done / e + 1) * e);
    return next;
  };

  // Ctrl-C and SIGTERM (caught since the output file's creation) are read between chunks: a chunk ends at the
  // next step an output is due at, or sooner.
  StopCadence cadence;
  const long first = sim.step_count();
  Progress progress(steps, sim.particle_count(), first);
  long done = first;
  bool aggregated = stop_at_aggregation && std::isfinite(sim.get("aggregation_time"));
  bool stopping = false;   // the signal read once a pass: the pass that sees it records the state and ends the loop
  try {
    while (done < steps && !stopping && !aggregated) {
      const long due = next_stop(done);
      const long n = std::min(due, done + cadence.steps()) - done;
      const auto chunk_start = std::chrono::steady_clock::now();
      sim.step_n(n);
      cadence.ran(n, std::chrono::duration<double>(std::chrono::steady_clock::now() - chunk_start).count());
      done += n;
      if (done == due) aggregated = stop_at_aggregation && std::isfinite(sim.get("aggregation_time"));
      stopping = stop_requested() && done < steps && !aggregated;   // a run that reached its end is complete
      const bool last = done == steps || aggregated || stopping;   // an interrupted run records where it stopped
      if (done % obs_every == 0 || last) write_observables(out, sim);
      if ((snap_every > 0 && done % snap_every == 0) || last) write_frame(out, sim);
      // Before a checkpoint, whose state knows the warning was given: the energy check's (also raised by the
      // aggregation test's read of the outputs).
      write_new_warnings(out, sim, warnings_written);
      // A stopped run always leaves one, so that `grains resume` can continue it.
      if ((checkpoint_every > 0 && done % checkpoint_every == 0 && !last) || stopping)
        out.write_checkpoint({.step = done, .time = sim.time(), .wall_seconds = earlier_seconds + progress.elapsed_seconds(),
                              .threads = sim.threads(), .state = sim.save_state(), .observables_at_step = done % obs_every == 0,
                              .frame_at_step = snap_every > 0 && done % snap_every == 0});
      if (!quiet) progress.update(done);
    }
  } catch (const std::exception& e) {
    progress.finish();
    mark_failed(out, sim, e);
    throw;
  }
  progress.finish();
  if (stopping) {
    out.set_attribute("status", fmt::format("interrupted at step {}", sim.step_count()));
  } else {
    out.set_attribute("status", "complete");
  }
  if (scene.boolean("analysis.collision_log")) {   // the full event log beside the counts
    std::vector<double> table;
    for (const CollisionEvent& e : sim.collision_events())
      table.insert(table.end(), {double(e.i), double(e.j), e.start, e.end, e.impact_speed, e.rebound_speed, double(e.adhesive)});
    out.write_table("collisions", {"i", "j", "start", "end", "impact_speed", "rebound_speed", "adhesive"}, table);
  }
  const double seconds = progress.elapsed_seconds();
  const double rate = seconds > 0 ? double(done - first) * double(sim.particle_count()) / seconds : 0.0;
  // The file's figures are the whole run's, a resumed run's earlier processes included (the summary's, this one's).
  const double total_seconds = earlier_seconds + seconds;
  out.set_scalar("wall_seconds", total_seconds);
  out.set_scalar("particle_steps_per_second",
                 total_seconds > 0 ? double(done) * double(sim.particle_count()) / total_seconds : 0.0);
  out.set_attribute("pair_loop_build", pair_filter::isa_name(pair_filter::isa()));
  out.flush();

  // One-screen summary.
  fmt::print("grains {}: scene '{}' ({}D, {} particles)\n", GRAINS_VERSION, scene.text("scene.name"), sim.dimension(),
             sim.particle_count());
  fmt::print("  steps        {} of dt = {:.6g}  (t = {:.6g}){}\n", sim.step_count(), sim.dt(), sim.time(),
             stopping ? fmt::format("  INTERRUPTED (continue it with grains resume {})", out.path())
                      : aggregated ? "  stopped at the aggregation (analysis.stop_at_aggregation)" : std::string());
  if (first > 0) fmt::print("  resumed      at step {} (the wall time, rate and first kinetic energy below are since then)\n", first);
  fmt::print("  wall time    {:.2f} s  ({:.3g} particle-steps/s, {} thread(s), pair loop {})\n", seconds, rate, sim.threads(),
             pair_filter::isa_name(pair_filter::isa()));
  fmt::print("  kinetic energy  {:.6g} -> {:.6g}\n", initial_energy, sim.get("kinetic_energy"));
  // Whatever of these the scene's modules provide.
  for (const char* name : {"contacts", "max_overlap_ratio", "clamped_contacts_total", "neighbour_builds",
                           "gravity_potential_energy", "virial_ratio", "time_over_free_fall", "cluster_count",
                           "cluster_index", "largest_cluster_fraction", "aggregation_time", "fractal_dimension", "normalised_stiffness",
                           "collision_count", "adhesive_collision_count", "adhesive_collision_fraction",
                           "open_collision_count",
                           // a pressure-controlled cell: where the barostat got to (only in the file until 2026-12-07)
                           "pressure_target", "pressure_reduced", "solid_fraction", "equilibrium", "coordination"}) {
    try {
      fmt::print("  {:<27} {:.6g}\n", name, sim.get(name));
    } catch (const SimulationError&) {
    }
  }
  try {   // the aggregation time in free-fall times (NaN when the threshold was never reached)
    fmt::print("  {:<27} {:.6g}\n", "aggregation_time / t_ff", sim.get("aggregation_time") / sim.get("free_fall_time"));
  } catch (const SimulationError&) {
  }
  fmt::print("  warnings     {}\n", run_warnings(scene, sim).size());
  fmt::print("  output       {}\n", out.path());
  return stopping ? 130 : 0;
}

}  // namespace

int run_scene(const RunOptions& opt) {
  // Everything that can be checked is checked before the output file is opened.
  Scene scene = Scene::from_file(opt.scene, opt.overrides);
  scene.validate();   // all its problems at once, before the output's name reads scene.name or output.file alone
  const auto [path, source] = hdf5_output_name(scene, opt.output, ".h5");
  // Looked at before the simulation is built: a child process reads it first, and no OpenMP thread may run yet.
  const ResumableOutput existing(path, opt.overwrite);
  PreparedRun prepared = prepare_run(scene, !opt.quiet);
  auto& sim = prepared.sim;
  if (!prepared.steps) scene.fail("time.duration", "give time.duration, time.steps or time.free_fall_times: how long to run");

  check_hdf5_output_path(path, opt.scene, scene, source);
  existing.refuse_replacing_it(source, "--out");

  std::vector<bool> periodic = sim->box().periodic;
  // From here on Ctrl-C ends the run with a valid file; one that came in the meantime leaves the file untouched.
  catch_stop_signals();
  if (stop_requested()) return 130;
  H5mdWriter out(path, sim->dimension(), periodic, GRAINS_VERSION, scene.resolved_toml(), scene.boolean("output.xdmf"));
  begin_output(out, scene, *sim, run_warnings(scene, *sim));
  return continue_run(scene, *sim, out, *prepared.steps, prepared.stop_at_aggregation, opt.quiet, 0.0);
}

int resume_plain_run(const std::string& path, const Scene& scene, RunCheckpoint& cp, bool quiet) {
  PreparedRun prepared = prepare_run(scene, !quiet);   // the scene's particles, which the checkpoint's replace
  if (!prepared.steps) scene.fail("time.duration", "the stored scene gives no run length: not a `grains run` output");
  restore_checkpoint(*prepared.sim, path, cp);
  // From here on Ctrl-C ends the run with a valid file; one that came in the meantime leaves the file untouched.
  catch_stop_signals();
  if (stop_requested()) return 130;
  H5mdWriter out(path, cp, scene.boolean("output.xdmf"), observable_names(*prepared.sim));
  out.set_attribute("status", fmt::format("resumed at step {}", cp.step));
  out.flush();
  if (!quiet) fmt::print(stderr, "resuming '{}' at step {} of {} (t = {:.6g})\n", path, cp.step, *prepared.steps, cp.time);
  return continue_run(scene, *prepared.sim, out, *prepared.steps, prepared.stop_at_aggregation, quiet, cp.wall_seconds);
}

}  // namespace grains
