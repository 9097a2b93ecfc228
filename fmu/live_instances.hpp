// The instances and FMU states handed to the host, for FMI 2 and 3 alike. The host gets opaque handles,
// never addresses: handles are not reused (by either kind), so a pointer the host has freed already (a second
// free, a call after free, even after a new instance or state took the old memory) is refused, never
// dereferenced.
#pragma once
#include <memory>

#include "instance.hpp"

namespace grains::fmu {

// Registers the instance and returns its handle for the host (nullptr stays nullptr).
void* hand_out(std::unique_ptr<Instance> instance);
// The instance behind a host's handle, or nullptr when it was never handed out or is freed.
Instance* live_instance(const void* handle);
// Deletes a live instance and the states it handed out; any other handle is left alone.
void free_instance(const void* handle);

// FMU states belong to the instance that made them (get or deserialize): FMI moves a state to another
// instance only as serialized bytes.
void* hand_out_state(const Instance& owner, std::unique_ptr<SavedState> state);
// The owner's state behind a host's handle; throws std::invalid_argument naming what is wrong (freed or never
// handed out, or another instance's) for the caller to log.
SavedState& live_state(const Instance& owner, const void* handle);
// Deletes the owner's state; throws like live_state for any other handle.
void free_state(const Instance& owner, const void* handle);

}  // namespace grains::fmu
