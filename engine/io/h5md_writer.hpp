// Run output in the H5MD 1.1 layout (particles/all/*, observables/*, parameters/) plus an XDMF
// companion for ParaView. The HDF5 types stay inside the .cpp so users of this header need no hdf5.h.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace grains {

struct RunCheckpoint;

// One particle snapshot; the writer copies nothing, the pointers need only live for the call.
struct H5mdFrame {
  long step = 0;
  double time = 0.0;
  int dimension = 3;                       // 2 or 3
  std::size_t count = 0;
  const double* position = nullptr;        // count*dimension
  const double* velocity = nullptr;        // count*dimension
  const double* radius = nullptr;          // count
  const double* mass = nullptr;            // count
  const double* angular_velocity = nullptr; int angular_components = 0;  // count*components, may be null
  const double* orientation = nullptr; int orientation_components = 0;   // count*4 (w,x,y,z) or count*1, may be null
  // count*dimension periodic images (unwrapped = position + image * box_length); null without a periodic axis.
  const std::int64_t* image = nullptr;
  const double* box_lower = nullptr;       // dimension
  const double* box_length = nullptr;      // dimension
};

class H5mdWriter {
 public:
  // Creates (truncates) `path`; throws std::runtime_error naming the path when that fails.
  H5mdWriter(const std::string& path, int dimension, const std::vector<bool>& boundary_periodic,
             const std::string& creator_version, const std::string& resolved_scene_toml, bool write_xdmf);
  // Reopens a run's file to continue it from its checkpoint (h5md_checkpoint.hpp, read_checkpoint's): every record,
  // frame and warning written after it is dropped, and the records at its step unless the checkpoint says they are the
  // unbroken run's; appending goes on from there. The file is checked whole first, `observables` (those the run
  // records) among it, and refused (std::runtime_error naming it) as it was.
  H5mdWriter(const std::string& path, const RunCheckpoint& resume, bool write_xdmf,
             const std::vector<std::string>& observables = {});
  ~H5mdWriter();
  H5mdWriter(const H5mdWriter&) = delete;
  H5mdWriter& operator=(const H5mdWriter&) = delete;

  void write_frame(const H5mdFrame& f);    // appends to particles/all/*, then flushes
  // Held in memory and written with the next flush: the first write of a later step flushes once a second
  // has passed since the last, so a killed run's file holds whole records (one step's observables).
  void write_observable(const std::string& name, long step, double time, double value);
  // The same for /grains/trace/<name>: a series recorded at other steps than the observables and the frames (grains
  // consolidate's trace within its stages), kept out of /observables, whose readers may take a record per frame.
  void write_trace(const std::string& name, long step, double time, double value);
  void write_warning(const std::string& text);                        // appends to /grains/warnings
  void set_attribute(const std::string& name, const std::string& value);  // string attribute on /grains
  void set_scalar(const std::string& name, double value);                 // double attribute on /grains
  // /grains/<name>: a [rows, columns] table of doubles (row-major `values`), its column names in the
  // attribute `columns`; written once (a second call replaces it).
  void write_table(const std::string& name, const std::vector<std::string>& columns, const std::vector<double>& values);
  void flush();                             // writes pending observables; the file stays readable if the process dies afterwards
  // The complete state at `step` (Simulation::save_state), in the older of two slots, so a run killed while
  // writing one keeps the other; the records up to `step` are flushed first (h5md_checkpoint.hpp reads it).
  // Stores checkpoint's step, stage, unreached, time, wall_seconds, cvode_seconds, state, stage_progress and *_at_step flags, and the
  // warnings so far.
  void write_checkpoint(const RunCheckpoint& checkpoint);

  const std::string& path() const;
  const std::string& xdmf_path() const;     // empty when XDMF is off

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace grains
