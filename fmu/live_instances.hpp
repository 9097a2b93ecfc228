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
// FMI allows one call at a time on an instance. A call claims its instance for the calling thread under the
// registry's lock, so that no free slips in between finding the instance and claiming it; the same thread may call
// again from inside (a host's logger calling back). Another thread's call is refused: `busy` then holds the message,
// and the logger to say it with (copied, since the instance may be freed as soon as the lock is let go).
struct Claim {
  Instance* instance = nullptr;   // nullptr: never handed out, freed, or busy
  bool outermost = false;         // this call claimed it, and releases it (release_instance)
  Instance::Logger busy_logger;
  std::string busy;               // non-empty: refused, another thread is inside a call on it
};
Claim claim_instance(const void* handle, const char* function);
// Ends the outermost call's claim; a free the host asked for during the call is done now.
void release_instance(const void* handle);
// Deletes a live instance and the states it handed out; any other handle is left alone. Asked during a call on the
// instance (from another thread, or from inside it, a logger calling back), it is done when that call ends.
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
