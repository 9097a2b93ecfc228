// Reading a run's checkpoint back (see h5md_checkpoint.hpp; H5mdWriter::write_checkpoint writes it).
#include "io/h5md_checkpoint.hpp"

#include <stdexcept>

#include <fmt/format.h>

#include "io/h5md_hdf5.hpp"

namespace grains {

RunCheckpoint read_checkpoint(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  hid_t fid = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (fid < 0) h5::fail(path, "opening it as a grains run's output, to resume it,");
  const h5::Handle file(fid, H5Fclose);
  if (!h5::exists(fid, "grains", path) || !h5::exists(fid, "parameters", path))
    throw std::runtime_error(fmt::format("'{}' is not the output of a grains run (no /grains or /parameters group)", path));
  const h5::Handle g = h5::open_group(fid, "grains", path);
  if (const std::string status = h5::read_attr_string(g.get(), "status", "", path); status == "complete")
    throw std::runtime_error(fmt::format("'{}' holds a complete run (status 'complete'): nothing to resume", path));
  RunCheckpoint cp;
  int slot = -1;
  for (int k : {0, 1}) {
    if (!h5::exists(g.get(), checkpoint_slot_name(k), path)) continue;
    const h5::Handle d = h5::open_dataset(g.get(), checkpoint_slot_name(k), path);
    const double at = h5::read_attr_double(d.get(), "step", -1, path);
    if (h5::read_attr_double(d.get(), "valid", 0, path) == 1 && (slot < 0 || at > double(cp.step))) slot = k, cp.step = long(at);
  }
  if (slot < 0 && !h5::read_attr_string(g.get(), "stage_table", "", path).empty())
    throw std::runtime_error(fmt::format("'{}' has no checkpoint to resume from: the programme stopped before its first "
                                         "stage ended (each stage but the last ends with one); run it again", path));
  if (slot < 0)
    throw std::runtime_error(fmt::format(
        "'{}' has no checkpoint to resume from: the run stopped before its first one (output.checkpoint_every sets "
        "the steps between them; with 0, the default, only a run stopped by Ctrl-C or SIGTERM writes one)", path));
  const h5::Handle d = h5::open_dataset(g.get(), checkpoint_slot_name(slot), path);
  cp.stage = int(h5::read_attr_double(d.get(), "stage", -1, path));
  cp.time = h5::read_attr_double(d.get(), "time", 0, path);
  cp.wall_seconds = h5::read_attr_double(d.get(), "wall_seconds", 0, path);
  cp.state.resize(h5::shape(d.get(), path, checkpoint_slot_name(slot)).at(0));
  if (!cp.state.empty())
    h5::check(H5Dread(d.get(), H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, cp.state.data()), path, "reading the checkpoint");
  cp.scene_toml = h5::read_dataset_string(fid, "parameters/scene.toml", path);
  cp.stage_table = h5::read_attr_string(g.get(), "stage_table", "", path);
  return cp;
}

}  // namespace grains
