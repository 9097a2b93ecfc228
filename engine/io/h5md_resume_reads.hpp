// Everything `grains resume` has HDF5 decode in a run's file, read once without changing it: for a child process
// to read before the resume does (runner/resume_probe.hpp), since HDF5 1.10.8 crashes on some damaged headers.
#pragma once
#include <functional>
#include <string>

namespace grains {

// Opens `path` read-only and reads every object under /particles, /observables, /grains and /parameters (each
// group's and dataset's attributes with their values, each dataset's type, shape, layout, chunk index and virtual
// mappings, each series' steps and times) but the XDMF views of the frames a resume keeps, then both checkpoints
// (read_checkpoint). Passes over every error: only whether HDF5 survives the reading matters. Reads nothing of a file
// another process is writing. Calls `reading` before each read with what it is about to read ("/grains/checkpoint_1",
// "/grains's attribute 'status'", ...): for a watcher, to say where HDF5 died or got stuck, and that it is not stuck.
void read_what_a_resume_reads(const std::string& path, const std::function<void(const std::string&)>& reading) noexcept;

}  // namespace grains
