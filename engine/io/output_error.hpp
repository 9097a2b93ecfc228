// An output file could not be written (a full disk, a size limit, an I/O error). The run itself was sound,
// so a file stopped by one says so and stays resumable from its last checkpoint once the cause is removed;
// a run's own error would only come back.
#pragma once
#include <stdexcept>

namespace grains {

struct OutputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace grains
