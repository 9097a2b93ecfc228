#include "consolidate_command.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "interactions/pair_filter.hpp"
#include "io/file_kind.hpp"
#include "io/h5md_checkpoint.hpp"
#include "io/h5md_writer.hpp"
#include "io/output_error.hpp"
#include "io/scene.hpp"
#include "output_paths.hpp"
#include "progress.hpp"
#include "protocols/consolidation_programme.hpp"
#include "resumable_output.hpp"
#include "resume_command.hpp"
#include "run_output.hpp"
#include "stop_signal.hpp"

namespace grains {

namespace {

// The columns grains writes to a stage table, in order (P_star, phi, branch: the columns runner/consolidation_fit.py
// reads), for the outputs of `sim`.
std::string stage_table_header(const Simulation& sim) {
  std::string header = "stage,phase,branch,target_pressure,P_star,phi,reached,steps,time,quench_start,quench_drag";
  for (const auto& n : stage_record_names(sim)) header += ',' + n;
  return header;
}

// The header and the rows of stages 0 .. last of a stage table (a resumed programme rewrites the rest), without their
// line ends; none when no stage had finished (the header comes with stage 0's row).
struct KeptTable {
  std::vector<std::string> lines;
  std::string eol = "\n";   // the header's line end, which the rows written on keep (a table saved with CRLF)
};
KeptTable table_up_to(const std::string& table, int last) {
  KeptTable kept;
  if (last < 0) return kept;
  std::ifstream in(table);
  std::string line;
  for (int row = -1; row <= last && std::getline(in, line); ++row) {
    const bool crlf = !line.empty() && line.back() == '\r';
    if (crlf) line.pop_back();
    if (row < 0 && crlf) kept.eol = "\r\n";
    if (row >= 0 && line.substr(0, line.find(',')) != std::to_string(row))
      throw std::runtime_error(fmt::format("'{}': line {} should be stage {}, and reads '{}'", table, row + 2, row,
                                           line.substr(0, 40)));
    kept.lines.push_back(line);
  }
  if (long(kept.lines.size()) != last + 2)
    throw std::runtime_error(fmt::format("'{}' has {} stage rows, fewer than the {} finished before the checkpoint", table,
                                         std::max(0L, long(kept.lines.size()) - 1), last + 1));
  return kept;
}

// A stage table line's fields (grains writes no quoted commas).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> out;
  std::size_t from = 0;
  for (std::size_t comma; (comma = line.find(',', from)) != std::string::npos; from = comma + 1)
    out.push_back(line.substr(from, comma - from));
  out.push_back(line.substr(from));
  return out;
}

// The new rows go in grains' column order: under a header with its columns moved or removed (a spreadsheet's edit)
// they would put values under other names, or more fields than the header has.
void check_table_header(const std::string& table, const std::string& found, const std::string& written,
                        const std::string& path) {
  if (found == written) return;
  // The first column that differs, field by field (a header one column short named the last column that matched)
  const auto a = csv_fields(found), b = csv_fields(written);
  const std::size_t column = std::mismatch(a.begin(), a.end(), b.begin(), b.end()).first - a.begin();
  throw std::runtime_error(fmt::format(
      "'{}': its stage table '{}' has the header '{}', where grains writes '{}' (they differ from column {} on): the "
      "resumed stages' rows would go under other columns; restore the header and the rows' columns as grains wrote "
      "them, or run the programme again", path, table, found, written, column + 1));
}

// A kept table's rows repeat the file's stage records (P_star and phi as the rows print them): else another run has
// rewritten the table since, and a resume would go on below its rows.
void check_rows_match_records(const std::string& table, const std::vector<std::string>& kept, const RunCheckpoint& cp,
                              const std::string& path) {
  if (kept.empty() || cp.stage_pressure.size() != kept.size() || cp.stage_solid_fraction.size() != kept.size()) return;
  const auto header = csv_fields(kept[0]);
  const auto column = [&](const char* name) { return std::find(header.begin(), header.end(), name) - header.begin(); };
  const std::size_t p = column("P_star"), phi = column("phi");
  for (std::size_t row = 1; row < kept.size(); ++row) {
    const auto f = csv_fields(kept[row]);
    const std::string want_p = fmt::format("{:.9g}", cp.stage_pressure[row]), want_phi = fmt::format("{:.9g}", cp.stage_solid_fraction[row]);
    if (p >= f.size() || phi >= f.size() || f[p] != want_p || f[phi] != want_phi)
      throw std::runtime_error(fmt::format(
          "'{}': its stage table '{}' is not the one the programme wrote: stage {}'s row has P_star = {}, phi = {} where "
          "the file's stage record has {}, {} (another run has written the table since?); restore the table, or run "
          "the programme again", path, table, row - 1, p < f.size() ? f[p] : "(none)", phi < f.size() ? f[phi] : "(none)",
          want_p, want_phi));
  }
}

// The outputs `grains consolidate` traces within stages (programme.trace_every): what shows a stage's course, each
// cheap to evaluate (no elastic moduli, no histograms).
std::vector<std::string> traced_outputs(const Simulation& sim) {
  std::vector<std::string> names;
  for (const char* n : {"pressure_reduced", "pressure_target", "solid_fraction", "coordination", "kinetic_energy",
                        "equilibrium_force", "equilibrium_torque", "equilibrium_stress", "equilibrium_kinetic", "bonded_clusters"})
    if (sim.has(n)) names.emplace_back(n);
  return names;
}

// The programme from `from` on, its table rows, records, checkpoints and summary: shared by a fresh
// programme and a resumed one (which comes in with the stages that missed their budget and the wall time
// before it).
int run_stages(const Scene& scene, const ProgrammeSettings& settings, Simulation& sim, H5mdWriter& out,
               std::ofstream& csv, const std::string& table, const std::string& eol, bool quiet, const StageProgress& from, long unreached,
               double earlier_seconds, double earlier_cvode) {
  const std::string path = out.path(), name = scene.text("scene.name");
  const int stages = int(programme_stages(settings).size());
  const long first_step = sim.step_count();
  // The file holds the start-up warnings (begin_output, or the programme being resumed): only later ones are
  // written, after each stage (a stage's target pressure beyond what the clamped contacts carry).
  std::size_t warnings_written = sim.warnings().size();
  bool clamp_warned = false;   // a stage ended with contacts past the overlap clamp (said once)
  fmt::print("grains {}: consolidation programme of '{}' ({}D, {} particles, preparation {})\n", GRAINS_VERSION, name,
             sim.dimension(), sim.particle_count(), settings.preparation);
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  StatusLine status;
  // The next output.checkpoint_every checkpoint: at the first check past the next multiple of N after the last
  // checkpoint, whichever wrote it. A stage's end counts: a resume from there cannot know that a multiple fell
  // in the stage's last steps, so the unbroken programme must not write one at the next stage's first check
  // either (the two files would hold different checkpoints).
  const long checkpoint_every = scene.integer("output.checkpoint_every");
  const auto next_multiple = [&] { return checkpoint_every > 0 ? (sim.step_count() / checkpoint_every + 1) * checkpoint_every : -1; };
  long next_checkpoint = next_multiple();
  // A checkpoint after stage `last` (with `progress`: inside the stage after it), the schedule counted from it.
  auto checkpoint = [&](int last, std::vector<double> progress) {
    // Before the state, which knows the warnings were given (a stage's target beyond the clamp, raised at its start).
    write_new_warnings(out, sim, warnings_written);
    out.write_checkpoint({.step = sim.step_count(), .stage = last, .unreached = unreached, .time = sim.time(),
                          .wall_seconds = earlier_seconds + status.elapsed_seconds(),
                          .cvode_seconds = earlier_cvode + sim.get("cvode_seconds"), .threads = sim.threads(), .gravity_kernels = gravity_kernels(),
                          .state = sim.save_state(),
                          .stage_progress = std::move(progress)});
    next_checkpoint = next_multiple();
  };
  // The target pressure in stage r now: none in the aggregation's fixed cell (r.target NaN, as in the stage table),
  // whatever cell.pressure holds; else the barostat's (below r.target while a first compression ramps). For the
  // trace, the stage records and the status line alike.
  const auto target_now = [&](const StageRecord& r) {
    return r.phase == "aggregation" ? r.target : sim.get("pressure_target");
  };
  // The trace (programme.trace_every): a row at the current step of stage r, `value` giving each traced output.
  const long trace_every = scene.integer("programme.trace_every");
  const std::vector<std::string> traced = traced_outputs(sim);
  const auto write_trace_row = [&](const StageRecord& r, const auto& value) {
    const long step = sim.step_count();
    for (const auto& n : traced) out.write_trace(n, step, sim.time(), value(n));
    out.write_trace("stage", step, sim.time(), double(r.index));
  };
  auto on_stage = [&](const StageRecord& r) {
    if (r.index == 0) csv << stage_table_header(sim) << eol;
    // The stage record: the programme's values, and the stage's target (not a table column: target_pressure is).
    auto recorded = r.values;
    recorded.emplace_back("pressure_target", target_now(r));
    // The record's value of n; `otherwise` for a name it does not hold.
    auto value = [&](const std::string& n, double otherwise = std::nan("")) {
      for (const auto& [k, v] : recorded)
        if (k == n) return v;
      return otherwise;
    };
    const std::string branch = r.phase == "unloading"                      ? "unloading"
                               : r.phase == "loading" || (r.phase == "equilibrate" && r.target == settings.start_pressure)
                                   ? "loading"
                                   : "preparation";
    // quench_start: steps into the stage when the quench was switched on; quench_drag: its gamma T at the
    // end (both empty: never quenched).
    const bool quenched = r.quench_start >= 0;
    const std::string quench = quenched ? fmt::format("{},{:.6g}", r.quench_start, r.quench_drag) : std::string(",");
    csv << fmt::format("{},{},{},{:.9g},{:.9g},{:.9g},{},{},{:.9g},{}", r.index, r.phase, branch, r.target,
                       value("pressure_reduced"), value("solid_fraction"), int(r.reached), r.steps, r.time, quench);
    for (const auto& [n, v] : r.values) csv << fmt::format(",{:.9g}", v);
    csv << eol << std::flush;
    if (!csv)
      throw OutputError(
          fmt::format("cannot write stage {}'s row to the stage table '{}' ({})", r.index, table, std::strerror(errno)));
    write_observables(out, sim, recorded);   // the row's values: the network's mark has moved on since
    out.write_observable("quench_start", sim.step_count(), sim.time(), quenched ? double(r.quench_start) : std::nan(""));
    out.write_observable("quench_drag", sim.step_count(), sim.time(), quenched ? r.quench_drag : std::nan(""));
    // The trace's row at the stage's end, the record's state, so that a stage's course reaches it: on_check is not
    // called at the check that ends a stage, so the step has no row yet. Before the checkpoint below, which holds it.
    if (trace_every > 0)
      write_trace_row(r, [&](const std::string& n) { return value(n, sim.get(n)); });
    write_frame(out, sim);
    status.finish();
    write_new_warnings(out, sim, warnings_written);
    // Contacts past the overlap clamp carry a capped force: the stage's equilibrium is that of another law ("equilibrium"
    // at P* = 2000 with the largest overlap twice the clamp), which the outputs' count alone does not say. Said at the
    // first such stage.
    if (const double clamped = sim.has("clamped_contacts") ? sim.get("clamped_contacts") : 0.0; clamped > 0 && !clamp_warned) {
      clamp_warned = true;
      const std::string what = fmt::format(
          "stage {} ({}{}) ended with {:.0f} contact(s) past the overlap clamp (max_overlap_ratio {:.4g} of the smaller "
          "radius, contact.overlap_limit {:.4g}): their elastic force is capped, so this state is not an equilibrium of "
          "the scene's law; raise adhesion.stiffness or contact.overlap_limit, or stay at lower pressures (later stages "
          "of this run are not warned of again: clamped_contacts in their records)",
          r.index, r.phase, std::isnan(r.target) ? std::string() : fmt::format(", P* = {:.4g}", r.target), clamped,
          sim.get("max_overlap_ratio"), scene.real("contact.overlap_limit"));
      fmt::print(stderr, "warning: {}\n", what);
      out.write_warning(what);
    }
    if (!r.reached) {
      ++unreached;
      // A ramped first compression's budget counts from the ramp's end.
      const long budget = r.phase == "aggregation" ? settings.aggregation_budget : settings.stage_budget;
      const std::string ramp = r.steps > budget ? fmt::format(" after its {}-step ramp", r.steps - budget) : "";
      // The aggregation runs in a fixed cell: no target pressure (NaN in the table) to print.
      const bool fixed_cell = std::isnan(r.target);
      fmt::print(stderr, "warning: stage {} ({} {}) did not reach {} within its budget of {} steps{}\n", r.index, r.phase,
                 fixed_cell ? "in its fixed cell" : fmt::format("at P* = {:.4g}", r.target),
                 r.phase == "aggregation" ? "one cluster" : "equilibrium", budget, ramp);
      out.write_warning(fmt::format("stage {} ({}, {}) not reached within {} steps", r.index, r.phase,
                                    fixed_cell ? "fixed cell" : fmt::format("P* = {:.6g}", r.target), r.steps));
    }
    // The end of every stage but the last (its row, records and warning written) is a checkpoint for `grains
    // resume`. Saving changes nothing (the state carries what rebuilds CVODE's history): the programme runs as
    // it would without checkpoints.
    if (r.index + 1 < stages) checkpoint(r.index, {});
    // A network that does not resist some strain has B or G = 0; one with negative stiffness directions has no
    // moduli (NaN): say so rather than print numbers without saying what they are.
    const double mechanisms = value("moduli_mechanisms"), unstable = value("moduli_unstable_modes");
    if (unstable > 0)
      fmt::print(stderr, "warning: stage {}: the contact network has {} negative stiffness direction(s) (distant bonds' "
                 "-F0/D0 not held): no elastic moduli\n", r.index, unstable);
    std::string moduli;
    if (unstable > 0)
      moduli = fmt::format("  B, G undefined ({} negative stiffness direction(s))", unstable);
    else if (!std::isnan(value("B")))
      moduli = fmt::format("  B {:.4g}  G {:.4g}{}", value("B"), value("G"),
                           mechanisms > 0 ? fmt::format(" (mechanism in {} strain direction(s))", mechanisms) : "");
    const std::string quench_note =
        quenched ? fmt::format("  quenched from step {} (drag gamma T {:.3g})", r.quench_start, r.quench_drag) : "";
    if (!quiet)
      fmt::print("  stage {:>2} {:<11} P* {:<9} {:<11} {:>9} steps  Phi {:.4f}  z {:.3f}{}{}\n", r.index, r.phase,
                 std::isnan(r.target) ? std::string("-") : fmt::format("{:.4g}", r.target), r.reached ? (r.phase == "aggregation" ? "one cluster" : "equilibrium") : "NOT REACHED", r.steps, value("solid_fraction"),
                 value("coordination"), quench_note, moduli);
    std::fflush(stdout);
  };
  // Within a stage, at an equilibrium check: a checkpoint every output.checkpoint_every steps, and one where
  // Ctrl-C or SIGTERM stops the programme; then what the stage waits for (one bonded cluster, or the four
  // equilibrium ratios falling below 1).
  bool stopped = false;   // the signals are caught since the output file's creation
  auto on_check = [&](const StageRecord& r, long budget, const StageProgress& at) {
    // The trace, before a checkpoint at the same step, which then holds it. Only at the checks proper (every
    // check_every steps into a stage; a stop request also calls here in between; the check that ends a stage comes
    // not here but to on_stage, which writes its row), and decided by the step alone, so that a resumed programme
    // writes the records the unbroken one does.
    const long step = sim.step_count();
    if (trace_every > 0 && r.steps % settings.check_every == 0 && step / trace_every != (step - settings.check_every) / trace_every)
      write_trace_row(r, [&](const std::string& n) { return n == "pressure_target" ? target_now(r) : sim.get(n); });
    stopped = stop_requested();
    if (stopped || (next_checkpoint > 0 && sim.step_count() >= next_checkpoint)) checkpoint(at.stage - 1, at.values());
    if (stopped) {
      status.finish();
      out.set_attribute("status", fmt::format("interrupted in stage {} at step {}", at.stage, sim.step_count()));
      out.flush();
    }
    if (stopped || quiet || !status.due()) return stopped;
    const double rate = double(sim.step_count() - first_step) * double(sim.particle_count()) / status.elapsed_seconds();
    // While a first compression ramps (programme.first_compression_time), the target it has reached.
    const double target = target_now(r);
    const std::string ramp = target < r.target ? fmt::format(" (ramping: target {:.4g})", target) : "";
    const std::string waiting =
        r.phase == "aggregation"
            ? fmt::format("clusters {:.0f}", sim.get("bonded_clusters"))
            : fmt::format("P* {:.4g}{}  equilibrium ratios force {:.3g} torque {:.3g} stress {:.3g} kinetic {:.3g}",
                          sim.get("pressure_reduced"), ramp, sim.get("equilibrium_force"), sim.get("equilibrium_torque"),
                          sim.get("equilibrium_stress"), sim.get("equilibrium_kinetic"));
    const std::string quench = r.quench_start >= 0 ? fmt::format("  quench from {}", r.quench_start) : "";
    status.show(fmt::format("  stage {} {} step {}/{}  Phi {:.4f}  {}{}  {:.3g} particle-steps/s", r.index, r.phase,
                            r.steps, budget, sim.get("solid_fraction"), waiting, quench, rate));
    return false;
  };
  // Between checks too: a programme.check_every of millions of steps held a Ctrl-C for minutes.
  const auto records = [&] {
    try {
      return run_programme(sim, settings, on_stage, on_check, from,
                           StopPoll{stop_requested, stop_check_steps(sim.particle_count())});
    } catch (const std::exception& e) {
      status.finish();
      mark_failed(out, sim, e);
      throw;
    }
  }();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cvode = sim.get("cvode_seconds");
  const double rate = seconds > 0 ? double(sim.step_count() - first_step) * double(sim.particle_count()) / seconds : 0.0;
  if (!stopped)
    out.set_attribute("status", unreached ? fmt::format("complete; {} stage(s) did not reach equilibrium", unreached)
                                          : std::string("complete"));
  // The file's figures are the whole programme's, a resumed one's earlier processes included (the summary's, this one's).
  const double total_seconds = earlier_seconds + seconds;
  out.set_scalar("wall_seconds", total_seconds);
  out.set_scalar("particle_steps_per_second",
                 total_seconds > 0 ? double(sim.step_count()) * double(sim.particle_count()) / total_seconds : 0.0);
  out.set_scalar("cvode_share", total_seconds > 0 ? (earlier_cvode + cvode) / total_seconds : 0.0);
  out.set_attribute("pair_loop_build", pair_filter::isa_name(pair_filter::isa()));
  out.flush();
  const long finished = from.stage + long(records.size());
  if (stopped)
    fmt::print("  stages       {} of {} finished ({} not reached)  INTERRUPTED in stage {} (continue it with grains resume {})\n",
               finished, stages, unreached, finished, out.path());
  else
    fmt::print("  stages       {} ({} not reached)\n", finished, unreached);
  if (first_step > 0)
    fmt::print("  resumed      at step {}, {} steps into stage {} (the wall time, rate and CVODE figures below are since "
               "then)\n", first_step, from.steps, from.stage);
  fmt::print("  steps        {} of dt = {:.6g}  (t = {:.6g})\n", sim.step_count(), sim.dt(), sim.time());
  fmt::print("  wall time    {:.2f} s  ({:.3g} particle-steps/s, {} thread(s), pair loop {})\n", seconds, rate, sim.threads(),
             pair_filter::isa_name(pair_filter::isa()));
  fmt::print("  CVODE        {:.3f} s = {:.2f} % of the wall time ({} internal steps, {} restarts)\n", cvode,
             seconds > 0 ? 100 * cvode / seconds : 0.0, sim.get("cvode_steps"), sim.get("cvode_reinitialisations"));
  fmt::print("  table        {}\n  output       {}\n", table, path);
  return stopped ? 130 : 0;
}

}  // namespace

int consolidate_scene(const ConsolidateOptions& opt) {
  Scene scene = Scene::from_file(opt.scene, opt.overrides);
  scene.validate();
  const ProgrammeSettings settings = ProgrammeSettings::from_scene(scene);
  ProgrammeSettings::refuse_floor_above_drag(scene);
  const std::string name = scene.text("scene.name");
  const auto [path, source] = hdf5_output_name(scene, opt.output, "-stages.h5");
  // Looked at before the simulation is built: a child process reads it first, and no OpenMP thread may run yet.
  const ResumableOutput existing(path, opt.overwrite);
  auto sim = create_simulation(scene, !opt.quiet);
  settings.check_time_step(scene, sim->dt());
  std::string table = opt.table.empty() ? name + "-stages.csv" : opt.table;
  check_hdf5_output_path(path, opt.scene, scene, source);
  check_output_path(table, opt.scene, scene, opt.table.empty() ? "scene.name (the default stage table <scene.name>-stages.csv)" : "--table");
  if (same_file(path, table))
    throw SceneError(fmt::format("the stage table and the HDF5 output are the same file '{}': name two (--table, --out)", path));
  if (const auto xdmf = xdmf_beside(path, scene); xdmf && same_file(*xdmf, table))
    throw SceneError(fmt::format("{}: stage table '{}' is the XDMF file written beside the HDF5 output '{}': name another "
                                 "file (or set output.xdmf = false)", opt.table.empty() ? "scene.name" : "--table", table, path));
  existing.refuse_replacing_it(source, "--out and --table", !opt.quiet);

  // From here on Ctrl-C ends the run with a valid file; one that came in the meantime leaves the file untouched.
  catch_stop_signals();
  if (stop_requested()) return 130;
  H5mdWriter out(path, sim->dimension(), sim->box().periodic, GRAINS_VERSION, scene.resolved_toml(),
                 scene.boolean("output.xdmf"));
  // For `grains resume`: the table relative to this file's folder (a campaign folder may be moved or copied whole).
  const auto folder = std::filesystem::absolute(path).parent_path();
  out.set_attribute("stage_table", std::filesystem::absolute(table).lexically_relative(folder).string());
  std::vector<std::string> warnings = sim->warnings();
  for (const char* key : {"time.duration", "time.steps", "time.free_fall_times"})   // a scene shared with `grains run`
    if (scene.has(key))
      warnings.push_back(fmt::format("{} is not used by grains consolidate: each stage runs until equilibrium or its budget "
                                     "(programme.stage_budget, programme.aggregation_budget)", key));
  // Not refused: tests and quick looks run tiny budgets on purpose; but every such stage ends NOT REACHED.
  if (!settings.budget_can_confirm())
    warnings.push_back(fmt::format("programme.stage_budget = {} holds fewer than the programme.confirm_checks = {} "
                                   "checks (one every programme.check_every = {} steps, and one at the budget's end) that "
                                   "confirm an equilibrium: no stage can reach equilibrium",
                                   settings.stage_budget, settings.quench.confirm_checks, settings.check_every));
  // A type-2 sample starts in the aggregation's fixed cell: no target yet (NaN, as that stage's record says),
  // whatever cell.pressure holds for the stages after it.
  const double initial_target = settings.preparation == "type2" ? std::nan("") : sim->get("pressure_target");
  begin_output(out, scene, *sim, warnings, {{"pressure_target", initial_target}});
  // The stage records' own two, for the initial state too: every stage record then has the frames' steps (readers
  // such as MDAnalysis take the observables' rows by the frame's index; one of these a row short made it fail).
  for (const char* name : {"quench_start", "quench_drag"}) out.write_observable(name, 0, sim->time(), std::nan(""));
  std::ofstream csv(table);
  if (!csv) throw SceneError(fmt::format("cannot write the stage table '{}'", table));
  return run_stages(scene, settings, *sim, out, csv, table, "\n", opt.quiet, {}, 0, 0.0, 0.0);
}

int resume_consolidation(const std::string& path, const Scene& scene, RunCheckpoint& cp, bool quiet) {
  scene.validate();
  const ProgrammeSettings settings = ProgrammeSettings::from_scene(scene);
  // A checkpoint ends every stage but the last: one after any later stage is no checkpoint this programme wrote.
  const int stages = int(programme_stages(settings).size());
  if (cp.stage > stages - 2)
    throw std::runtime_error(fmt::format("H5MD output '{}': its checkpoint's attribute 'stage' is {}, where a programme of "
                                         "{} stages writes one in [-1, {}]: the file is damaged and cannot be continued",
                                         path, cp.stage, stages, stages - 2));
  auto sim = create_simulation(scene, !quiet);   // the scene's particles, which the checkpoint's replace
  restore_checkpoint(*sim, path, cp);
  StageProgress from{cp.stage + 1, 0, {}};
  if (!cp.stage_progress.empty()) try {   // stopped inside a stage
      from = StageProgress::from_values(cp.stage_progress, settings, sim->dt());
      if (from.stage != cp.stage + 1)
        throw std::invalid_argument(fmt::format("stage {} under way after stage {}", from.stage, cp.stage));
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(fmt::format("'{}': its checkpoint's stage_progress does not fit the stored programme ({})", path, e.what()));
    }
  const std::string table = (std::filesystem::absolute(path).parent_path() / cp.stage_table).lexically_normal().string();
  if (const auto kind = not_a_regular_file(table))
    throw std::runtime_error(fmt::format("'{}': its stage table '{}' is {}, not the file the programme wrote; resuming "
                                         "needs that file", path, table, *kind));
  if (!std::filesystem::is_regular_file(table))
    throw std::runtime_error(fmt::format("'{}': its stage table '{}' is gone; resuming needs it", path, table));
  const KeptTable kept = table_up_to(table, cp.stage);
  if (!kept.lines.empty()) check_table_header(table, kept.lines[0], stage_table_header(*sim), path);
  check_rows_match_records(table, kept.lines, cp, path);
  // From here on Ctrl-C ends the run with a valid file; one that came in the meantime leaves the file untouched.
  catch_stop_signals();
  if (stop_requested()) return 130;
  // Each stage record holds the simulation's observables, the stage's target and its quench.
  std::vector<std::string> recorded = observable_names(*sim);
  recorded.insert(recorded.end(), {"pressure_target", "quench_start", "quench_drag"});
  // The kept rows go to a new file that then takes the table's name: a kill at any moment leaves the old table
  // or the new one whole, never a table cut short (which the next resume would refuse). A link to the table
  // stays a link: the file it names is the one replaced, from its own folder (rename stays on one file system).
  // That file is written before the HDF5 file is checked and cut, and removed if the HDF5 file is refused: a table
  // that cannot be written leaves both files as they were, and so does a refused HDF5 file.
  const std::string target = std::filesystem::canonical(table).string(), rewritten = target + ".resuming";
  const auto remove_rewritten = [&] {
    std::error_code ignored;
    std::filesystem::remove(rewritten, ignored);
  };
  {
    std::ofstream part(rewritten, std::ios::trunc);
    for (const auto& line : kept.lines) part << line << kept.eol;
    part.close();
    if (!part) {
      remove_rewritten();
      throw std::runtime_error(fmt::format("cannot write the stage table '{}'", rewritten));
    }
  }
  const auto checked_and_cut = [&] {
    try {
      return H5mdWriter(path, cp, scene.boolean("output.xdmf"), recorded);
    } catch (...) {
      remove_rewritten();
      throw;
    }
  };
  H5mdWriter out = checked_and_cut();
  std::error_code renamed;
  std::filesystem::rename(rewritten, target, renamed);
  if (renamed) {   // the file is cut back to the checkpoint, the old table whole: the next resume cuts that table too
    remove_rewritten();
    throw std::runtime_error(fmt::format("cannot replace the stage table '{}' ({})", table, renamed.message()));
  }
  std::ofstream csv(table, std::ios::app);
  if (!csv) throw std::runtime_error(fmt::format("cannot write the stage table '{}'", table));
  out.set_attribute("status", fmt::format("resumed in stage {} at step {}", from.stage, cp.step));
  warn_of_other_gravity_kernels(path, scene, cp, out);
  if (!quiet)
    fmt::print(stderr, "resuming '{}' {} steps into stage {} (step {}, t = {:.6g})\n", path, from.steps, from.stage, cp.step, cp.time);
  return run_stages(scene, settings, *sim, out, csv, table, kept.eol, quiet, from, cp.unreached, cp.wall_seconds, cp.cvode_seconds);
}

}  // namespace grains
