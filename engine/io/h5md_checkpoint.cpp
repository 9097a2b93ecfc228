// Reading a run's checkpoint back (see h5md_checkpoint.hpp; H5mdWriter::write_checkpoint writes it).
#include "io/h5md_checkpoint.hpp"

#include <span>
#include <stdexcept>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/byte_stream.hpp"
#include "io/h5md_checkpoint_slots.hpp"
#include "io/h5md_hdf5.hpp"

namespace grains {

namespace {
// The ranges of a checkpoint's attributes: a stage's index fits an int, the threads any machine's processor count
// (automatic threads go up to it, past run.threads' 1024), and times lie far inside a double's (any value the writer
// stores).
constexpr double kMaxStage = 2147483647, kMaxThreads = 1 << 20, kHuge = 1e300;
}  // namespace

std::string scene_check_sum(const std::string& scene_toml) {
  return fmt::format("{:016x}", check_sum(std::as_bytes(std::span(scene_toml.data(), scene_toml.size()))));
}

RunCheckpoint read_checkpoint(const std::string& path, int skip) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (h5::locked_by_another_process(path))
    throw std::runtime_error(fmt::format("cannot resume '{}': another process is writing it (a run or a resume still "
                                         "going on); wait for it to end, or stop it first", path));
  hid_t fid = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (fid < 0) h5::fail(path, "opening it as a grains run's output, to resume it,");
  const h5::Handle file(fid, H5Fclose);
  if (!h5::exists(fid, "grains", path) || !h5::exists(fid, "parameters", path))
    throw std::runtime_error(fmt::format("'{}' is not the output of a grains run (no /grains or /parameters group)", path));
  const h5::Handle g = h5::open_group(fid, "grains", path);
  // A run ends "complete"; a programme "complete" or "complete; N stage(s) did not reach equilibrium".
  const std::string status = h5::read_attr_string(g.get(), "status", "", path);
  if (status.rfind("complete", 0) == 0)
    throw std::runtime_error(fmt::format("'{}' holds a finished run (status '{}'): nothing to resume", path, status));
  // A run stopped by an error would meet it again from any checkpoint: the same state, the same steps.
  if (status.rfind("failed", 0) == 0)
    throw std::runtime_error(fmt::format("'{}' holds a run that ended with an error (status '{}'): resuming would "
                                         "repeat it; change what the error names and run the scene again", path, status));
  const std::string stage_table = h5::read_attr_string(g.get(), "stage_table", "", path);
  const auto slots = valid_checkpoint_slots(g.get(), path);
  RunCheckpoint cp;
  int readable = 0;
  for (const auto& [slot, step] : slots) {
    const h5::Handle d = h5::open_dataset(g.get(), checkpoint_slot_name(slot), path);
    // Read whole into a buffer of its first axis: one axis of bytes, as create_checkpoint_slot makes it (a slot of two
    // axes overflowed the buffer).
    const std::vector<hsize_t> shape = h5::shape(d.get(), path, checkpoint_slot_name(slot));
    const h5::Handle type(h5::check(H5Dget_type(d.get()), path, "reading the type of a checkpoint"), H5Tclose);
    if (shape.size() != 1 || H5Tget_class(type.get()) != H5T_INTEGER)
      throw std::runtime_error(fmt::format("H5MD output '{}': /grains/{} holds {} of the shape {}, where grains writes one "
                                           "axis of bytes: the file is damaged and cannot be continued", path,
                                           checkpoint_slot_name(slot), shape.size() != 1 ? "values" : "non-integers",
                                           shape.empty() ? "of a scalar" : fmt::format("{}", fmt::join(shape, " x "))));
    cp.state.resize(shape[0]);
    // A slot whose checksum fails (damaged on disk) is passed over like an invalid one, and named to the caller.
    if (!cp.state.empty() && H5Dread(d.get(), H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, cp.state.data()) < 0) {
      cp.damaged_newer_step = long(step);
      cp.damaged_newer_stage = int(h5::read_attr_in(d.get(), "stage", -1, -1, kMaxStage, true, path));
      continue;
    }
    if (readable++ < skip) continue;
    // Each attribute in what the writer stores, before it is converted (1e300 converted to a long was undefined).
    cp.step = long(step);
    cp.stage = int(h5::read_attr_in(d.get(), "stage", -1, -1, kMaxStage, true, path));
    cp.unreached = long(h5::read_attr_in(d.get(), "unreached", 0, 0, cp.stage + 1, true, path));
    cp.time = h5::read_attr_in(d.get(), "time", 0, -kHuge, kHuge, false, path);
    cp.wall_seconds = h5::read_attr_in(d.get(), "wall_seconds", 0, 0, kHuge, false, path);
    cp.cvode_seconds = h5::read_attr_in(d.get(), "cvode_seconds", 0, 0, kHuge, false, path);
    cp.threads = int(h5::read_attr_in(d.get(), "threads", 0, 0, kMaxThreads, true, path));
    cp.stage_progress = h5::read_attr_doubles(d.get(), "stage_progress", path);
    cp.observables_at_step = h5::read_attr_in(d.get(), "observables_at_step", 1, 0, 1, true, path) == 1;
    cp.frame_at_step = h5::read_attr_in(d.get(), "frame_at_step", 1, 0, 1, true, path) == 1;
    // At most the rows the file holds: later warnings may follow the checkpoint's, none go.
    const double warning_rows = h5::exists(g.get(), "warnings", path)
        ? double(h5::shape(h5::open_dataset(g.get(), "warnings", path).get(), path, "/grains/warnings").at(0)) : 0;
    cp.warnings = long(h5::read_attr_in(d.get(), "warnings", -1, -1, warning_rows, true, path));
    cp.scene_toml = h5::read_dataset_string(fid, "parameters/scene.toml", path);
    const std::string written_with = h5::read_attr_string(d.get(), "scene_check_sum", "", path);   // "": before 2026-12-05
    if (!written_with.empty() && written_with != scene_check_sum(cp.scene_toml))
      throw std::runtime_error(fmt::format(
          "'{}': its stored scene (parameters/scene.toml) is not the one its checkpoints were written with: it was "
          "edited since, and a resume would go on with other settings; run the edited scene from the start instead", path));
    cp.status = status;
    cp.scene_directory = h5::read_attr_string(g.get(), "scene_directory", "", path);
    cp.stage_table = stage_table;
    // The records up to the checkpoint's stage only: what a kill left after them may not read back (the resume
    // repairs it); those before were flushed with the checkpoint. Unreadable, they are not compared.
    if (!stage_table.empty()) try {
        for (auto [name, values] : {std::pair{"pressure_reduced", &cp.stage_pressure},
                                    std::pair{"solid_fraction", &cp.stage_solid_fraction}}) {
          const std::string record = std::string("observables/") + name + "/value";
          const h5::Handle v = h5::open_dataset(fid, record, path);
          for (int row = 0; row <= cp.stage + 1; ++row) values->push_back(h5::read_row(v.get(), row, path, record).at(0));
        }
      } catch (const std::exception&) {
        H5Eclear2(H5E_DEFAULT);
        cp.stage_pressure.clear(), cp.stage_solid_fraction.clear();
      }
    // The first frame, each element shaped as grains writes it (frames x particles, x the dimension for the position):
    // another shape read as a row of another length, said to be a changed particle file.
    const int dim = h5::exists(fid, "particles/all/box", path)
        ? int(h5::read_attr_in(h5::open_group(fid, "particles/all/box", path).get(), "dimension", 3, 2, 3, true, path)) : 3;
    for (auto [name, values] :
         {std::pair{"radius", &cp.radius}, std::pair{"mass", &cp.mass}, std::pair{"position", &cp.position}}) {
      const std::string element = std::string("/particles/all/") + name + "/value";
      if (h5::exists(fid, std::string("particles/all/") + name, path)) {
        const h5::Handle v = h5::open_dataset(fid, element, path);
        const std::vector<hsize_t> shape = h5::shape(v.get(), path, element);
        const h5::Handle type(h5::check(H5Dget_type(v.get()), path, "reading the type of " + element), H5Tclose);
        const bool position = values == &cp.position;
        const std::string expected = position ? fmt::format("frames x particles x {}", dim) : "frames x particles";
        if (shape.size() != (position ? 3u : 2u) || (position && shape[2] != hsize_t(dim)) ||
            H5Tget_class(type.get()) != H5T_FLOAT || shape[0] == 0)
          throw std::runtime_error(fmt::format("H5MD output '{}': {} holds {} of the shape {}, where grains writes floats "
                                               "of the shape {} (one frame at least): the file is damaged and cannot be "
                                               "continued", path, element, H5Tget_class(type.get()) == H5T_FLOAT ? "floats" : "non-floats",
                                               shape.empty() ? "of a scalar" : fmt::format("{}", fmt::join(shape, " x ")),
                                               expected));
        *values = h5::read_row(v.get(), 0, path, element);
      }
    }
    return cp;
  }
  H5Eclear2(H5E_DEFAULT);
  if (readable > 0)   // skip = 1 and one readable slot
    throw std::runtime_error(fmt::format("'{}' has no older checkpoint to fall back on", path));
  if (!slots.empty())
    throw std::runtime_error(fmt::format("'{}': its checkpoints are damaged (their checksums fail): nothing to resume from", path));
  if (!stage_table.empty())
    throw std::runtime_error(fmt::format(
        "'{}' has no checkpoint to resume from: the programme was killed before its first (one is written at the end "
        "of every stage but the last, where Ctrl-C or SIGTERM stops it, and every output.checkpoint_every steps); run "
        "it again", path));
  throw std::runtime_error(fmt::format(
      "'{}' has no valid checkpoint to resume from: the run stopped before its first one (output.checkpoint_every sets "
      "the steps between them; with 0, the default, only a run stopped by Ctrl-C or SIGTERM writes one)", path));
}

}  // namespace grains
