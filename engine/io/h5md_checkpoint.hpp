// A run's checkpoint in its own H5MD file: the complete simulation state at a step, kept in two slots
// (/grains/checkpoint_0 and _1, one-axis byte datasets) written alternately. A slot's `valid` attribute
// is cleared before its bytes are written and set after them, each change flushed, so a run killed
// mid-write leaves the other slot, and `grains resume` continues from the newest valid one.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace grains {

// What H5mdWriter::write_checkpoint stores (the fields up to frame_at_step) and read_checkpoint gives back.
struct RunCheckpoint {
  long step = 0;
  int stage = -1;                         // `grains consolidate`: the programme's last finished stage; -1: `grains run`
  long unreached = 0;                     // `grains consolidate`: stages up to `stage` that missed their budget
  double time = 0, wall_seconds = 0;      // simulated time; wall time of the run up to the checkpoint
  double cvode_seconds = 0;               // CVODE's share of that wall time (a pressure-controlled cell)
  // The worker threads the run used (0: not recorded, a file older than the record): a resume uses as many, since the
  // sums' order, and so the results' last bits, depend on the count (automatic counts follow the cores).
  int threads = 0;
  // The gravity kernels' instruction set ("avx512", "avx2", "portable"; "" where not recorded): their sums' last bits
  // differ between sets, unlike the pair loop's, so a resume on another processor continues with other bits.
  std::string gravity_kernels;
  std::vector<std::byte> state;           // Simulation::save_state()
  // `grains consolidate` stopped inside a stage (StageProgress::values(): the stage under way, its steps and
  // its quench's counters); empty: at the end of `stage`.
  std::vector<double> stage_progress;
  // Whether the observable records and the frame written at `step` are the unbroken run's: a run stopped
  // between its scheduled records recorded where it stopped, and its resume drops those.
  bool observables_at_step = true, frame_at_step = true;
  long warnings = -1;                     // rows of /grains/warnings then (the writer counts them; -1: unknown)
  std::string status;                     // the file's /grains status then: "interrupted at step N", "running" (killed), ...
  std::string scene_toml;                 // the resolved scene the run was started with
  std::string scene_directory;            // where the scene's relative file paths lie (particles.file)
  std::string stage_table;                // `grains consolidate`: the stage table, relative to the file's folder
  // `grains consolidate`: P* and Phi of the stage records, the initial state's first (what the table's rows must
  // repeat, so that a resume does not go on from a table another run has rewritten).
  std::vector<double> stage_pressure, stage_solid_fraction;
  std::vector<double> radius, mass, position;   // the run's first frame: what a rebuilt simulation must have
  int slot = -1;                          // the slot it was read from: 0 or 1 (/grains/checkpoint_0, _1)
  // The slots marked valid that were passed over for it as damaged (their shape, an attribute, the checksum of their
  // bytes): each slot, and what is wrong with it said with its path ("the checkpoint in /grains/checkpoint_1 (step 400)
  // is damaged (its checksum fails)").
  struct PassedOver {
    int slot;
    std::string said;
  };
  std::vector<PassedOver> passed_over;
};

// Where a checkpoint stands, for messages: "step 400"; in a programme "step 400, after stage 2" ("in stage 0" before
// the first stage's end).
std::string checkpoint_place(long step, int stage, bool programme);

// The check sum of a stored scene's text, in hex: each checkpoint records that of the scene it continues, so that
// a resume refuses a scene edited in the file since (it would go on with other settings).
std::string scene_check_sum(const std::string& scene_toml);

// The newest valid checkpoint of the run output `path` that reads back whole (its shape and attributes as grains writes
// them, its bytes' checksum), or with `skip` = 1 the one before it; a damaged one is passed over (RunCheckpoint::
// passed_over). Throws std::runtime_error naming the file when it is not a grains run output, holds a finished run, or
// has no such checkpoint (each damaged one named with what is wrong with it).
RunCheckpoint read_checkpoint(const std::string& path, int skip = 0);

}  // namespace grains
