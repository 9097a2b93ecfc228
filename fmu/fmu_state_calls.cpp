#include "fmu_state_calls.hpp"

#include <cstring>
#include <memory>
#include <span>

#include <fmt/format.h>

#include "guarded_call.hpp"
#include "live_instances.hpp"

// States are handles of live_instances.cpp: one freed already, or another instance's, is refused with a message.
namespace grains::fmu::state_calls {
namespace {
// Get and deserialize: fill(state) writes into the state the host passes back (`handle` not null: reused) or into
// a new one, handed out only when filling it succeeded.
template <class Fill>
Status fill_state(const Instance& owner, void*& handle, Fill fill) {
  if (handle) return fill(live_state(owner, handle));
  auto state = std::make_unique<SavedState>();
  const Status status = fill(*state);
  if (status == Status::ok) handle = hand_out_state(owner, std::move(state));
  return status;
}
}  // namespace

Status get(const void* instance, const char* function, const char* argument, void** state) {
  return guarded_call(instance, function, [&](Instance& in) {
    if (!state) return in.error(fmt::format("{}: null {} pointer", function, argument));
    return fill_state(in, *state, [&](SavedState& saved) { return in.save(function, saved); });
  });
}

Status set(const void* instance, const char* function, const char* argument, const void* state) {
  return guarded_call(instance, function, [&](Instance& in) {
    if (!state) return in.error(fmt::format("{}: null {}", function, argument));
    return in.restore(function, live_state(in, state));
  });
}

Status free(const void* instance, const char* function, void** state) {
  return guarded_call(instance, function, [&](Instance& in) {
    if (state && *state) {
      free_state(in, *state);
      *state = nullptr;
    }
    return Status::ok;
  });
}

Status serialized_size(const void* instance, const char* function, const void* state, std::size_t* size) {
  return guarded_call(instance, function, [&](Instance& in) {
    if (!state || !size) return in.error(fmt::format("{}: null argument", function));
    *size = live_state(in, state).bytes.size();
    return Status::ok;
  });
}

Status serialize(const void* instance, const char* function, const void* state, void* bytes, std::size_t size) {
  return guarded_call(instance, function, [&](Instance& in) {
    if (!state || !bytes) return in.error(fmt::format("{}: null argument", function));
    const auto serialized = in.serialize(live_state(in, state));
    if (size != serialized.size())
      return in.error(fmt::format("{}: size {} given, the state has {} bytes", function, size, serialized.size()));
    std::memcpy(bytes, serialized.data(), size);
    return Status::ok;
  });
}

Status deserialize(const void* instance, const char* function, const void* bytes, std::size_t size, void** state) {
  return guarded_call(instance, function, [&](Instance& in) {
    if (!bytes || !state) return in.error(fmt::format("{}: null argument", function));
    const auto serialized = std::span(static_cast<const std::byte*>(bytes), size);
    return fill_state(in, *state, [&](SavedState& saved) { return in.deserialize(function, serialized, saved); });
  });
}

}  // namespace grains::fmu::state_calls
