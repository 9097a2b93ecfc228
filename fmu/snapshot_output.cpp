#include "snapshot_output.hpp"

#include <dlfcn.h>

#include <stdexcept>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/h5md_frame_view.hpp"
#include "resource_location.hpp"
#include "snapshot_plugin.hpp"

namespace grains::fmu {
SnapshotOutput::SnapshotOutput(const std::string& path, const Simulation& sim, const std::string& version,
                               const std::string& scene_toml) {
  const std::string plugin = (binary_directory() / snapshot_plugin_file).string();
  // Never unloaded: the HDF5 library it brings in leaves thread keys whose destructors run when a host thread that
  // wrote snapshots ends. Unloaded with the instance, HDF5 took those destructors' code with it, and the host
  // crashed when such a thread ended.
  library_ = dlopen(plugin.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  if (!library_)
    throw std::runtime_error(fmt::format("fmu.snapshots_every asks for HDF5 snapshots, but the snapshot plugin cannot be "
                                         "loaded: {} (it needs the HDF5 shared library, e.g. Debian's libhdf5-103-1; "
                                         "set fmu.snapshots_every = 0 to run without snapshots)", dlerror()));
  auto open = reinterpret_cast<grains_snapshot_open_fn>(dlsym(library_, "grains_snapshot_open"));
  write_ = dlsym(library_, "grains_snapshot_write");
  close_ = dlsym(library_, "grains_snapshot_close");
  if (!open || !write_ || !close_) {
    dlclose(library_);
    throw std::runtime_error(fmt::format("the snapshot plugin {} lacks its functions (from another build?)", plugin));
  }
  const auto box = sim.box();
  bool periodic[3] = {false, false, false};
  for (int a = 0; a < sim.dimension(); ++a) periodic[a] = box.periodic[a];
  char error[1024] = "";
  file_ = open(path.c_str(), sim.dimension(), periodic, version.c_str(), scene_toml.c_str(), error, sizeof error);
  if (!file_) {
    dlclose(library_);
    throw std::runtime_error(fmt::format("cannot create the snapshot file '{}': {}", path, error));
  }
}

SnapshotOutput::~SnapshotOutput() {
  reinterpret_cast<grains_snapshot_close_fn>(close_)(file_);
  dlclose(library_);
}

void SnapshotOutput::write(const Simulation& sim) {
  const ParticleView p = sim.particles();
  const BoxView b = sim.box();
  const H5mdFrame f = frame_view(sim.step_count(), sim.time(), p, b);
  char error[1024] = "";
  if (reinterpret_cast<grains_snapshot_write_fn>(write_)(file_, &f, error, sizeof error) != 0)
    throw std::runtime_error(fmt::format("writing a snapshot at step {} failed: {}", f.step, error));
}

}  // namespace grains::fmu
