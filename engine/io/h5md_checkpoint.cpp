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

// The bytes the slot `d` holds, refused (h5::Damaged) unless it is one axis of integers as create_checkpoint_slot makes
// it: a slot of two axes overflowed the buffer of its first axis it was read into.
std::size_t slot_bytes(hid_t d, const std::string& path) {
  const std::string where = h5::path_of(d, ".");
  const std::vector<hsize_t> shape = h5::shape(d, path, where);
  const h5::Handle type(h5::check(H5Dget_type(d), path, "reading the type of " + where), H5Tclose);
  if (shape.size() != 1 || H5Tget_class(type.get()) != H5T_INTEGER)
    throw h5::Damaged(path, fmt::format("{} holds {} of the shape {}, where grains writes one axis of bytes", where,
                                        shape.size() != 1 ? "values" : "non-integers",
                                        shape.empty() ? "of a scalar" : fmt::format("{}", fmt::join(shape, " x "))));
  return shape[0];
}

// The attributes of the slot `d` (its `step` as valid_checkpoint_slots read it) into `cp`, each refused (h5::Damaged)
// unless in what the writer stores, before it is converted (1e300 converted to a long was undefined). `warning_rows`:
// the rows /grains/warnings holds (later warnings may follow the checkpoint's, none go).
void read_slot_attributes(hid_t d, double step, double warning_rows, const std::string& path, RunCheckpoint& cp) {
  cp.step = long(step);
  cp.stage = int(h5::read_attr_in(d, "stage", -1, -1, kMaxStage, true, path));
  cp.unreached = long(h5::read_attr_in(d, "unreached", 0, 0, cp.stage + 1, true, path));
  cp.time = h5::read_attr_in(d, "time", 0, -kHuge, kHuge, false, path);
  cp.wall_seconds = h5::read_attr_in(d, "wall_seconds", 0, 0, kHuge, false, path);
  cp.cvode_seconds = h5::read_attr_in(d, "cvode_seconds", 0, 0, kHuge, false, path);
  cp.threads = int(h5::read_attr_in(d, "threads", 0, 0, kMaxThreads, true, path));
  cp.gravity_kernels = h5::read_attr_string(d, "gravity_kernels", "", path);
  cp.stage_progress = h5::read_attr_doubles(d, "stage_progress", path);
  cp.observables_at_step = h5::read_attr_in(d, "observables_at_step", 1, 0, 1, true, path) == 1;
  cp.frame_at_step = h5::read_attr_in(d, "frame_at_step", 1, 0, 1, true, path) == 1;
  cp.warnings = long(h5::read_attr_in(d, "warnings", -1, -1, warning_rows, true, path));
}
}  // namespace

std::string checkpoint_place(long step, int stage, bool programme) {
  return !programme ? fmt::format("step {}", step)
         : stage < 0 ? fmt::format("step {}, in stage 0", step)
                     : fmt::format("step {}, after stage {}", step, stage);
}

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
  const bool programme = !stage_table.empty();
  std::vector<std::pair<int, std::string>> damaged;   // slots whose 'valid' or 'step' do not read
  const auto slots = valid_checkpoint_slots(g.get(), path, &damaged);
  std::vector<RunCheckpoint::PassedOver> passed_over;
  for (const auto& [slot, defect] : damaged)
    passed_over.push_back({slot, fmt::format("the checkpoint in /grains/{} is damaged ({})", checkpoint_slot_name(slot), defect)});
  const double warning_rows = h5::exists(g.get(), "warnings", path)
      ? double(h5::shape(h5::open_dataset(g.get(), "warnings", path).get(), path, "/grains/warnings").at(0)) : 0;
  RunCheckpoint cp;
  int readable = 0;
  for (const auto& [slot, step] : slots) {
    // A slot that does not read back as grains writes it (its shape, an attribute, its bytes' checksum) is passed over
    // like an invalid one, and named to the caller: the other slot may be whole.
    std::string place = checkpoint_place(long(step), -1, false), defect, written_with;
    try {
      const h5::Handle d = h5::open_dataset(g.get(), checkpoint_slot_name(slot), path);
      cp.state.resize(slot_bytes(d.get(), path));
      read_slot_attributes(d.get(), step, warning_rows, path, cp);
      place = checkpoint_place(cp.step, cp.stage, programme);
      written_with = h5::read_attr_string(d.get(), "scene_check_sum", "", path);   // "": a file older than the attribute
      if (!cp.state.empty() && H5Dread(d.get(), H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, cp.state.data()) < 0)
        defect = "its checksum fails";
    } catch (const std::runtime_error& e) {
      defect = h5::defect_of(e);
    }
    if (!defect.empty()) {
      passed_over.push_back({slot, fmt::format("the checkpoint in /grains/{} ({}) is damaged ({})", checkpoint_slot_name(slot),
                                               place, defect)});
      continue;
    }
    if (readable++ < skip) continue;
    cp.slot = slot;
    cp.passed_over = passed_over;
    cp.scene_toml = h5::read_dataset_string(fid, "parameters/scene.toml", path);
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
  if (!passed_over.empty()) {
    std::string each;
    for (const auto& damaged_slot : passed_over) each += (each.empty() ? "" : "; ") + damaged_slot.said;
    throw std::runtime_error(fmt::format("'{}': nothing to resume from: {}", path, each));
  }
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
