// The instances handed to the host, for FMI 2 and 3 alike. A host may pass back a pointer it has
// freed already (a second free, a call after free): that pointer is refused, never dereferenced.
#pragma once
#include <memory>

#include "instance.hpp"

namespace grains::fmu {

// Registers the instance and returns it for the host (nullptr stays nullptr).
Instance* hand_out(std::unique_ptr<Instance> instance);
// The instance behind a host's pointer, or nullptr when it was never handed out or is freed.
Instance* live_instance(const void* pointer);
// Deletes a live instance; any other pointer is left alone.
void free_instance(const void* pointer);

}  // namespace grains::fmu
