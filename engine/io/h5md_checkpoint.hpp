// A run's checkpoint in its own H5MD file: the complete simulation state at a step, kept in two slots
// (/grains/checkpoint_0 and _1, one-axis byte datasets) written alternately. A slot's `valid` attribute
// is cleared before its bytes are written and set after them, each change flushed, so a run killed
// mid-write leaves the other slot, and `grains resume` continues from the newest valid one.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace grains {

inline const char* checkpoint_slot_name(int slot) { return slot == 0 ? "checkpoint_0" : "checkpoint_1"; }

struct RunCheckpoint {
  long step = 0;
  int stage = -1;                         // `grains consolidate`: the programme's last finished stage; -1: `grains run`
  double time = 0, wall_seconds = 0;      // simulated time; wall time of the run up to the checkpoint
  std::vector<std::byte> state;           // Simulation::save_state()
  std::string scene_toml;                 // the resolved scene the run was started with
  std::string stage_table;                // `grains consolidate`: the stage table's absolute path
};

// The newest valid checkpoint of the run output `path`. Throws std::runtime_error naming the file when it
// is not a grains run output, holds a complete run, or has no valid checkpoint.
RunCheckpoint read_checkpoint(const std::string& path);

}  // namespace grains
