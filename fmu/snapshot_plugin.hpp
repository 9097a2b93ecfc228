// The optional HDF5 snapshot plugin: a separate shared library (grains_snapshots.so, next to the FMU
// binary) that the FMU loads with dlopen only when fmu.snapshots_every > 0, so the FMU binary itself
// never depends on HDF5. Both sides are built from this header in the same build.
#pragma once
#include <cstddef>

#include "io/h5md_writer.hpp"

extern "C" {
// Opens PATH as an H5MD file (the runner's layout, XDMF beside it). Returns null and fills `error` on failure.
typedef void* (*grains_snapshot_open_fn)(const char* path, int dimension, const bool* periodic, const char* version,
                                         const char* scene_toml, char* error, std::size_t error_size);
// Appends one particle frame. Returns 0, or 1 and fills `error`.
typedef int (*grains_snapshot_write_fn)(void* file, const grains::H5mdFrame* frame, char* error, std::size_t error_size);
typedef void (*grains_snapshot_close_fn)(void* file);
}

namespace grains::fmu {
inline constexpr const char* snapshot_plugin_file = "grains_snapshots.so";
}
