// The HDF5 snapshot plugin (see snapshot_plugin.hpp): the runner's H5MD writer behind a C interface.
#include "snapshot_plugin.hpp"

#include <cstring>
#include <exception>
#include <string>
#include <vector>

#include <hdf5.h>

#define GRAINS_PLUGIN_EXPORT extern "C" __attribute__((visibility("default")))

namespace {
void copy_error(const char* what, char* error, std::size_t size) {
  if (error && size > 0) {
    std::strncpy(error, what, size - 1);
    error[size - 1] = '\0';
  }
}
}  // namespace

GRAINS_PLUGIN_EXPORT void* grains_snapshot_open(const char* path, int dimension, const bool* periodic, const char* version,
                                                const char* scene_toml, char* error, std::size_t error_size) {
  // Every HDF5 object is closed by its writer (at Terminate or FreeInstance). HDF5's own exit handler would close
  // them again and crash the host (SIGSEGV at its exit, after Terminate and FreeInstance have succeeded) where a
  // write has failed (a full disk, a file-size limit), as it would the runner. Asked
  // before this library's first HDF5 call; a host that loaded the same HDF5 library itself keeps its own choice.
  static const bool no_exit_handler = (H5dont_atexit(), true);
  (void)no_exit_handler;
  try {
    std::vector<bool> axes(periodic, periodic + dimension);
    return new grains::H5mdWriter(path, dimension, axes, version, scene_toml, true);
  } catch (const std::exception& e) {
    copy_error(e.what(), error, error_size);
  }
  return nullptr;
}

GRAINS_PLUGIN_EXPORT int grains_snapshot_write(void* file, const grains::H5mdFrame* frame, char* error, std::size_t error_size) {
  try {
    auto* writer = static_cast<grains::H5mdWriter*>(file);
    writer->write_frame(*frame);   // flushes: the file stays readable if the host dies
    return 0;
  } catch (const std::exception& e) {
    copy_error(e.what(), error, error_size);
  }
  return 1;
}

GRAINS_PLUGIN_EXPORT void grains_snapshot_close(void* file) {
  try {
    delete static_cast<grains::H5mdWriter*>(file);
  } catch (...) {
  }
}
