// The instances handed to the host, for FMI 2 and 3 alike. The host gets an opaque handle, never the
// instance's address: handles are not reused, so a pointer the host has freed already (a second free,
// a call after free, even after a new instance took the old memory) is refused, never dereferenced.
#pragma once
#include <memory>

#include "instance.hpp"

namespace grains::fmu {

// Registers the instance and returns its handle for the host (nullptr stays nullptr).
void* hand_out(std::unique_ptr<Instance> instance);
// The instance behind a host's handle, or nullptr when it was never handed out or is freed.
Instance* live_instance(const void* handle);
// Deletes a live instance; any other handle is left alone.
void free_instance(const void* handle);

}  // namespace grains::fmu
