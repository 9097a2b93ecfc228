// `grains resume`: the checkpoint read, the scene it was stored with, the simulation restored and checked;
// then the run or the programme goes on (run_command.cpp, consolidate_command.cpp).
#include "resume_command.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <fmt/format.h>

#include "consolidate_command.hpp"
#include "core/simulation.hpp"
#include "interactions/gravity_direct.hpp"
#include "io/file_kind.hpp"
#include "io/h5md_writer.hpp"
#include "io/scene.hpp"
#include "output_paths.hpp"
#include "resume_probe.hpp"
#include "run_command.hpp"

namespace grains {

namespace {

void check_records_at_step(const std::string& path, const Scene& scene, const RunCheckpoint& cp) {
  // Whether the records and the frame at the checkpoint's step are the unbroken run's follows from the stored cadences
  // (a programme records at its stages' ends, which its checkpoints count as theirs): a flag saying otherwise had the
  // resume drop a scheduled record and never write it again.
  const bool programme = !cp.stage_table.empty();
  const long obs_every = scene.integer("output.observables_every"), snap_every = scene.integer("output.snapshots_every");
  for (auto [name, flag, due, cadence] :
       {std::tuple{"observables_at_step", cp.observables_at_step, programme || cp.step % obs_every == 0,
                   fmt::format("output.observables_every = {}", obs_every)},
        std::tuple{"frame_at_step", cp.frame_at_step, programme || (snap_every > 0 && cp.step % snap_every == 0),
                   fmt::format("output.snapshots_every = {}", snap_every)}})
    if (flag != due)
      throw std::runtime_error(fmt::format(
          "H5MD output '{}': its checkpoint at step {} has the attribute '{}' = {}, where {} makes it {}: the file is "
          "damaged and cannot be continued", path, cp.step, name, int(flag),
          programme ? "a programme (its checkpoints come with its records)" : cadence, int(due)));
}

}  // namespace

int resume_run(const std::string& path, bool quiet) {
  // Before the child reads it: a FIFO would hold the child until its time runs out, and HDF5 reads a device as it is.
  if (const auto kind = not_a_regular_file(path))
    throw std::runtime_error(fmt::format("'{}' is {}: grains resume reads a regular file, the H5MD output that grains run "
                                         "or grains consolidate wrote; not resumed", path, *kind));
  // Then, while no OpenMP thread runs: a child reads the file, and a file HDF5 dies reading is refused.
  refuse_a_file_hdf5_dies_reading(path);
  RunCheckpoint cp = read_checkpoint(path);
  for (const auto& damaged : cp.passed_over)
    fmt::print(stderr, "warning: '{}': {} and is passed over; resuming from the one in /grains/checkpoint_{} ({})\n", path,
               damaged.said, cp.slot, checkpoint_place(cp.step, cp.stage, !cp.stage_table.empty()));
  // The XDMF file beside it is rewritten by a rename, which replaced a FIFO there and failed on a folder only after
  // the file and the stage table had been cut back to the checkpoint (the status left 'running'): refused first.
  const Scene scene = stored_scene(path, cp);
  if (const auto xdmf = xdmf_beside(path, scene))
    if (const auto kind = not_a_regular_file(*xdmf))
      throw std::runtime_error(fmt::format("'{}': the XDMF file the resume rewrites beside it, '{}', is {}: move that "
                                           "away (a regular file or nothing may be there); not resumed", path, *xdmf,
                                           *kind));
  check_records_at_step(path, scene, cp);
  // A programme's file names its stage table.
  return cp.stage_table.empty() ? resume_plain_run(path, scene, cp, quiet) : resume_consolidation(path, scene, cp, quiet);
}

std::string gravity_kernels() { return gravity_direct::isa_name(gravity_direct::fastest_isa()); }

void warn_of_other_gravity_kernels(const std::string& path, const Scene& scene, const RunCheckpoint& cp, H5mdWriter& out) {
  if (!scene.boolean("gravity.enabled") || cp.gravity_kernels.empty() || cp.gravity_kernels == gravity_kernels()) return;
  const std::string said = fmt::format(
      "resumed at step {} with the {} gravity kernels, where the run used {} (another processor, or GRAINS_GRAVITY_ISA): "
      "their sums differ in the last bits, so from step {} on this run is not the unbroken run bit for bit",
      cp.step, gravity_kernels(), cp.gravity_kernels, cp.step);
  fmt::print(stderr, "warning: '{}': {}\n", path, said);
  out.write_warning(said);
}

Scene stored_scene(const std::string& path, const RunCheckpoint& cp) {
  // The stored scene is the resolved one: every key written out, defaults included. The run's thread count
  // is kept (an automatic one follows the cores, which may be fewer now): it decides the results' last bits.
  // Set after reading, not as a --set override, which the scene's messages would count as the user's.
  Scene scene = Scene::from_string(cp.scene_toml, fmt::format("the scene stored in {}", path), {}, cp.scene_directory);
  if (cp.threads > 0) scene.set_value("run.threads", fmt::format("{}", cp.threads));
  scene.accept_unread_keys();
  return scene;
}

void restore_checkpoint(Simulation& sim, const std::string& path, RunCheckpoint& cp) {
  // The particles come from the stored scene again (particles.file among it): before the state replaces them, they
  // must be the run's first frame. Radii and masses, and positions, which set the run's length in free-fall
  // times, its t_ff and everything after.
  const ParticleView p = sim.particles();
  for (auto [name, rebuilt, stored] : {std::tuple{"radius", &p.radius, &cp.radius}, std::tuple{"mass", &p.mass, &cp.mass},
                                       std::tuple{"position", &p.position, &cp.position}}) {
    // Another count is no changed value: the frame's particles, or the scene's, are not the run's.
    const std::size_t per_particle = rebuilt->size() / std::max<std::size_t>(1, sim.particle_count());
    if (!stored->empty() && stored->size() != rebuilt->size())
      throw std::runtime_error(fmt::format(
          "H5MD output '{}': the run's first frame (/particles/all/{}/value) holds {} particles, where the stored scene "
          "builds {}: the file is damaged and cannot be continued", path, name, stored->size() / std::max<std::size_t>(1, per_particle),
          sim.particle_count()));
    if (!stored->empty() && *rebuilt != *stored)
      throw std::runtime_error(fmt::format(
          "'{}': the particles rebuilt from the stored scene have another {} than the run's first frame (a file the "
          "scene reads, such as particles.file under {}, has changed since the run started): not resumed", path, name,
          cp.scene_directory.empty() ? "the working folder" : cp.scene_directory));
  }
  try {
    sim.restore_state(cp.state);
  } catch (const SimulationError& e) {   // a state that does not fit: the older checkpoint, if there is one
    fmt::print(stderr, "warning: '{}': the checkpoint at step {} does not restore ({}); trying the one before it\n", path,
               cp.step, e.what());
    cp = read_checkpoint(path, 1);
    try {
      sim.restore_state(cp.state);
    } catch (const SimulationError& older) {
      throw std::runtime_error(fmt::format("'{}': neither checkpoint restores ({})", path, older.what()));
    }
  }
  if (sim.step_count() != cp.step)
    throw std::runtime_error(fmt::format("'{}': its checkpoint says step {} but holds the state of step {}", path, cp.step,
                                         sim.step_count()));
}

}  // namespace grains
