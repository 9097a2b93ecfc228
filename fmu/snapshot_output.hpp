// HDF5 particle snapshots from inside the FMU (parameter fmu.snapshots_every > 0), written through the
// plugin library grains_snapshots.so beside the FMU binary, loaded here with dlopen on first use.
#pragma once
#include <string>

namespace grains {
class Simulation;
}

namespace grains::fmu {

class SnapshotOutput {
 public:
  // Loads the plugin and creates `path`; throws std::runtime_error saying what is missing.
  SnapshotOutput(const std::string& path, const Simulation& sim, const std::string& version, const std::string& scene_toml);
  ~SnapshotOutput();
  SnapshotOutput(const SnapshotOutput&) = delete;
  SnapshotOutput& operator=(const SnapshotOutput&) = delete;
  void write(const Simulation& sim);   // one frame at the current step

 private:
  void* library_ = nullptr;
  void* file_ = nullptr;
  void* write_ = nullptr;
  void* close_ = nullptr;
};

}  // namespace grains::fmu
