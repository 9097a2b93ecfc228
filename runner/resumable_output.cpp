#include "resumable_output.hpp"

#include <exception>
#include <filesystem>
#include <optional>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/h5md_checkpoint.hpp"
#include "io/scene.hpp"
#include "progress.hpp"
#include "protocols/consolidation_programme.hpp"
#include "protocols/run_length.hpp"
#include "resume_command.hpp"
#include "resume_probe.hpp"

namespace grains {

namespace {

// The checkpoint `grains resume` would continue from, or none where it would refuse the file.
std::optional<RunCheckpoint> resumable_checkpoint(const std::string& path) {
  try {
    return read_checkpoint(path);
  } catch (const std::exception&) {   // not a grains output, finished, failed, no valid checkpoint, another's file
    return std::nullopt;
  }
}

// The stored run's length in steps, where the stored scene still builds (a particles.file gone: unknown). The
// resolved scenes compared leave out the thread count, which the stored one keeps (stored_scene) and which does
// not change the length; a particles file may have changed since, so a scene that reads one is built.
std::optional<long> run_length(const std::string& path, const RunCheckpoint& cp, bool show_progress,
                               const std::optional<RunAboutToStart>& now) {
  try {
    const Scene scene = stored_scene(path, cp);
    if (now && scene.text("particles.layout") != "file" && scene.directory() == now->scene.directory()) {
      Scene same_threads = scene;
      same_threads.set_value("run.threads", fmt::format("{}", now->scene.integer("run.threads")));
      if (same_threads.resolved_toml() == now->scene.resolved_toml()) return now->steps;
    }
    return run_steps(scene, *create_simulation(scene, show_progress));
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The stored programme's number of stages, where its settings still read.
std::optional<std::size_t> stage_count(const std::string& path, const RunCheckpoint& cp) {
  try {
    const Scene scene = stored_scene(path, cp);
    scene.validate();
    return programme_stages(ProgrammeSettings::from_scene(scene)).size();
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// Where the run in `path` stopped, as it continues: "a run interrupted at step 512 of 20000", ...
std::string where_it_stopped(const std::string& path, const RunCheckpoint& cp, bool show_progress,
                             const std::optional<RunAboutToStart>& now) {
  // Ctrl-C and SIGTERM leave "interrupted ...", with a checkpoint at that step; a killed run "running" (or
  // "resumed at step N"), an output error "stopped by an output error ...", each with its newest checkpoint.
  const bool interrupted = cp.status.rfind("interrupted", 0) == 0;
  const std::string unfinished = fmt::format("that did not finish (status '{}'), with a checkpoint", cp.status);
  if (!cp.stage_table.empty()) {
    const auto stages = stage_count(path, cp);
    return fmt::format("a consolidation programme {} at step {}, {} stage(s){} finished",
                       interrupted ? "interrupted" : unfinished, cp.step, cp.stage + 1,
                       stages ? fmt::format(" of its {}", *stages) : std::string());
  }
  const auto steps = run_length(path, cp, show_progress, now);
  return fmt::format("a run {} at step {}{}", interrupted ? "interrupted" : unfinished, cp.step,
                     steps ? fmt::format(" of {}", *steps) : std::string());
}

}  // namespace

ResumableOutput::ResumableOutput(const std::string& path, bool overwrite) : path_(path) {
  std::error_code ec;
  if (overwrite || !std::filesystem::is_regular_file(path, ec)) return;
  try {
    refuse_a_file_hdf5_dies_reading(path);
    readable_ = true;
  } catch (const std::exception&) {   // damaged: `grains resume` refuses it, so it is no run to keep
  }
}

void ResumableOutput::refuse_replacing_it(const std::string& source, const std::string& other_names,
                                          bool show_progress, std::optional<RunAboutToStart> about_to_start) const {
  if (!readable_) return;
  const auto cp = resumable_checkpoint(path_);
  if (!cp) return;
  throw SceneError(fmt::format("{}: output file '{}' holds {}; not written over: continue it with `grains resume {}`, "
                               "or replace it with --overwrite (or name another file: {})", source, path_,
                               where_it_stopped(path_, *cp, show_progress, about_to_start), path_, other_names));
}

}  // namespace grains
