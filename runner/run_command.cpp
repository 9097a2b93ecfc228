#include "run_command.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "interactions/pair_filter.hpp"
#include "io/h5md_checkpoint.hpp"
#include "io/h5md_writer.hpp"
#include "io/scene.hpp"
#include "output_paths.hpp"
#include "resumable_output.hpp"
#include "resume_command.hpp"
#include "progress.hpp"
#include "run_output.hpp"
#include "run_preparation.hpp"
#include "stop_cadence.hpp"
#include "stop_signal.hpp"

namespace grains {

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
                              .threads = sim.threads(), .gravity_kernels = gravity_kernels(), .state = sim.save_state(), .observables_at_step = done % obs_every == 0,
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
                           // a pressure-controlled cell: where the barostat got to
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
  existing.refuse_replacing_it(source, "--out", !opt.quiet, RunAboutToStart{scene, *prepared.steps});

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
  warn_of_other_gravity_kernels(path, scene, cp, out);
  out.flush();
  if (!quiet) fmt::print(stderr, "resuming '{}' at step {} of {} (t = {:.6g})\n", path, cp.step, *prepared.steps, cp.time);
  return continue_run(scene, *prepared.sim, out, *prepared.steps, prepared.stop_at_aggregation, quiet, cp.wall_seconds);
}

}  // namespace grains
