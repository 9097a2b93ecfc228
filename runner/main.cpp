// grains: command-line runner. `grains --help` lists the commands.
#include <new>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <hdf5.h>

#include "check_command.hpp"
#include "consolidate_command.hpp"
#include "io/scene.hpp"
#include "resume_command.hpp"
#include "run_command.hpp"

int main(int argc, char** argv) {
  // Every HDF5 object is closed by its owner before exit. HDF5's own exit handler would close them again and
  // crashes (SIGSEGV) on a file whose flush failed (a full disk), turning a clear error into a core dump.
  H5dont_atexit();
  CLI::App app{"grains " GRAINS_VERSION " - discrete element simulations of granular matter.\n"
               "Runs a scene file (TOML, see docs/scene-reference.md) and writes H5MD output.\n"
               "Example: grains run models/gas.toml --set contact.restitution=0.5 --out gas.h5"};
  app.require_subcommand(1);
  // Command-line mistakes exit with status 2, like the Python tools' (CLI11 has one code per kind of error).
  app.failure_message([](const CLI::App*, const CLI::Error& e) {
    return fmt::format("error: {}\nRun with --help for more information.\n", e.what());
  });

  // An empty file name given on purpose (--out '') fell back to the default name silently.
  const CLI::Validator file_name(
      [](std::string& name) { return name.empty() ? std::string("the file name is empty: name a file") : std::string(); },
      "FILE");
  // --set takes one value per occurrence: a vector option would swallow the scene after it (`run --set k=v SCENE`).
  grains::RunOptions run;
  auto* cmd_run = app.add_subcommand("run", "Run a scene and write its HDF5 (H5MD) output, an XDMF file and a summary");
  cmd_run->add_option("scene", run.scene, "Scene file (.toml)")->required()->check(CLI::ExistingFile);
  cmd_run->add_option("--set", run.overrides, "Override a scene key: --set section.key=value (repeatable)")
      ->allow_extra_args(false);
  cmd_run->add_option("--out", run.output, "Output HDF5 file (default: output.file or <scene.name>.h5)")->check(file_name);
  cmd_run->add_flag("--quiet", run.quiet, "No progress line");
  cmd_run->add_flag("--overwrite", run.overwrite, "Replace an output file that holds an interrupted run "
                                                  "(else refused: grains resume continues it)");

  grains::ConsolidateOptions cons;
  auto* cmd_cons = app.add_subcommand("consolidate", "Run a scene's consolidation programme (physics.md section 9): "
                                                     "preparation, stepwise loading and unloading, each stage to equilibrium; "
                                                     "one table row, H5MD observable record and snapshot per stage");
  cmd_cons->add_option("scene", cons.scene, "Scene file (.toml) with cell.enabled = true")->required()->check(CLI::ExistingFile);
  cmd_cons->add_option("--set", cons.overrides, "Override a scene key: --set section.key=value (repeatable)")
      ->allow_extra_args(false);
  cmd_cons->add_option("--out", cons.output, "Output HDF5 file (default output.file or <scene.name>-stages.h5)")->check(file_name);
  cmd_cons->add_option("--table", cons.table, "Stage table, CSV (default <scene.name>-stages.csv)")->check(file_name);
  cmd_cons->add_flag("--quiet", cons.quiet, "No line per stage");
  cmd_cons->add_flag("--overwrite", cons.overwrite, "Replace an output file that holds an interrupted programme "
                                                    "(else refused: grains resume continues it)");

  std::string resume_file;
  bool resume_quiet = false;
  auto* cmd_resume = app.add_subcommand("resume", "Continue a run that was stopped (Ctrl-C, SIGTERM) or killed, from the "
                                                  "newest checkpoint in its output file (output.checkpoint_every)");
  // Any existing path: resume_run says what is there when it is not a regular file (a folder, a FIFO, a device).
  cmd_resume->add_option("output", resume_file, "The run's HDF5 output file")->required()->check(CLI::ExistingPath);
  cmd_resume->add_flag("--quiet", resume_quiet, "No progress line");

  std::string check_scene;
  std::vector<std::string> check_overrides;
  auto* cmd_check = app.add_subcommand("check", "Validate a scene without running it; prints the resolved scene");
  cmd_check->add_option("scene", check_scene, "Scene file (.toml)")->required()->check(CLI::ExistingFile);
  cmd_check->add_option("--set", check_overrides, "Override a scene key (repeatable)")->allow_extra_args(false);

  auto* cmd_ref = app.add_subcommand("scene-reference", "Print the scene reference (every key, default and range) as Markdown");

  // A word that names no command: CLI11 would say only that a subcommand is required.
  if (argc > 1 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (const auto* sub : app.get_subcommands({})) {
      known |= sub->get_name() == argv[1];
      names += fmt::format("{}{}", names.empty() ? "" : ", ", sub->get_name());
    }
    if (!known) {
      fmt::print(stderr, "error: unknown command '{}': the commands are {} (grains --help)\n", argv[1], names);
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;   // --help and --version are not errors
  }
  try {
    if (*cmd_run) return grains::run_scene(run);
    if (*cmd_cons) return grains::consolidate_scene(cons);
    if (*cmd_resume) return grains::resume_run(resume_file, resume_quiet);
    if (*cmd_check) return grains::check_scene(check_scene, check_overrides);
    if (*cmd_ref) {
      fmt::print("{}", grains::schema_reference_markdown());
      return 0;
    }
  } catch (const std::bad_alloc&) {
    fmt::print(stderr, "error: out of memory: the scene needs more memory than this machine gives the run "
                       "(fewer particles, or output.snapshots_every = 0)\n");
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
  return 0;
}
