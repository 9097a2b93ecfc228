#include "live_instances.hpp"

#include <cstdint>
#include <map>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "worker_pool.hpp"

namespace grains::fmu {
namespace {
struct OwnedState {
  const Instance* owner;
  std::unique_ptr<SavedState> state;
};
// Instances may be created and freed from several host threads at once. Never destroyed, so that a
// host freeing its instances while the process exits still finds it.
struct Registry {
  std::mutex mutex;
  std::map<std::uintptr_t, std::unique_ptr<Instance>> instances;
  std::map<std::uintptr_t, OwnedState> states;
  std::uintptr_t next = 0x1000;   // handles of both kinds: aligned, never 0, never reused
  std::uintptr_t take_handle() {
    const std::uintptr_t handle = next;
    next += 16;
    return handle;
  }
};
Registry& registry() {
  static auto* r = new Registry;
  return *r;
}

// The entry of a state handle the owner may use; the registry's mutex is held by the caller.
std::map<std::uintptr_t, OwnedState>::iterator owned_state(const Instance& owner, const void* handle) {
  auto& states = registry().states;
  const auto it = states.find(reinterpret_cast<std::uintptr_t>(handle));
  if (it == states.end())
    throw std::invalid_argument(fmt::format("FMU state {} is not a live state: it was freed already, or never handed out by "
                                            "this FMU", handle));
  if (it->second.owner != &owner)
    throw std::invalid_argument(fmt::format("FMU state {} belongs to instance '{}', not to '{}': a state is only used by the "
                                            "instance that made it (serialize it to move it to another)",
                                            handle, it->second.owner->name(), owner.name()));
  return it;
}
}  // namespace

void* hand_out(std::unique_ptr<Instance> instance) {
  if (!instance) return nullptr;
  prepare_worker_pools();
  std::lock_guard lock(registry().mutex);
  const std::uintptr_t handle = registry().take_handle();
  registry().instances.emplace(handle, std::move(instance));
  return reinterpret_cast<void*>(handle);
}

Claim claim_instance(const void* handle, const char* function) {
  std::lock_guard lock(registry().mutex);
  const auto it = registry().instances.find(reinterpret_cast<std::uintptr_t>(handle));
  if (it == registry().instances.end()) return {};
  Instance& in = *it->second;
  const std::thread::id me = std::this_thread::get_id();
  if (in.caller == std::thread::id{}) {
    in.caller = me;
    return {&in, true, {}, {}};
  }
  if (in.caller == me) return {&in, false, {}, {}};
  return {nullptr, false, in.logger(),
          fmt::format("{}: called while another thread is inside a call on instance \"{}\": FMI 2 and 3 allow one call "
                      "at a time on an instance; give each thread its own instance, or let one call end before the next",
                      function, in.name())};
}

namespace {
// Takes the instance and its states out of the registry (its mutex held by the caller), for deleting outside it.
void take_out(std::map<std::uintptr_t, std::unique_ptr<Instance>>::iterator it, std::unique_ptr<Instance>& gone,
              std::vector<std::unique_ptr<SavedState>>& its_states) {
  gone = std::move(it->second);
  registry().instances.erase(it);
  // FMI: freeing an instance frees everything it allocated, the states the host did not free among them.
  auto& states = registry().states;
  for (auto s = states.begin(); s != states.end();)
    if (s->second.owner == gone.get()) {
      its_states.push_back(std::move(s->second.state));
      s = states.erase(s);
    } else {
      ++s;
    }
}

void delete_taken(std::unique_ptr<Instance>& gone, std::vector<std::unique_ptr<SavedState>>& its_states) {
  its_states.clear();   // deleted outside the lock
  gone.reset();
  // OpenMP's worker pool belongs to the calling host thread (libgomp); release it so no engine
  // thread outlives the instance. Another instance's next step simply starts a new pool.
  release_worker_pool();
}
}  // namespace

void release_instance(const void* handle) {
  std::unique_ptr<Instance> gone;
  std::vector<std::unique_ptr<SavedState>> its_states;
  {
    std::lock_guard lock(registry().mutex);
    const auto it = registry().instances.find(reinterpret_cast<std::uintptr_t>(handle));
    if (it == registry().instances.end()) return;
    it->second->caller = std::thread::id{};
    if (!it->second->free_asked) return;
    take_out(it, gone, its_states);
  }
  delete_taken(gone, its_states);
}

void free_instance(const void* handle) {
  std::unique_ptr<Instance> gone;
  std::vector<std::unique_ptr<SavedState>> its_states;
  {
    std::lock_guard lock(registry().mutex);
    const auto it = registry().instances.find(reinterpret_cast<std::uintptr_t>(handle));
    if (it == registry().instances.end()) return;   // freed before, or never ours: nothing to do
    // Not from under a call (another thread's, or this one's from inside it: FMI forbids both): done when it ends.
    if (it->second->caller != std::thread::id{}) {
      it->second->free_asked = true;
      return;
    }
    take_out(it, gone, its_states);
  }
  delete_taken(gone, its_states);
}

void* hand_out_state(const Instance& owner, std::unique_ptr<SavedState> state) {
  std::lock_guard lock(registry().mutex);
  const std::uintptr_t handle = registry().take_handle();
  registry().states.emplace(handle, OwnedState{&owner, std::move(state)});
  return reinterpret_cast<void*>(handle);
}

// The reference outlives the lock: the state is only freed through its owner, and FMI forbids concurrent
// calls on one instance.
SavedState& live_state(const Instance& owner, const void* handle) {
  std::lock_guard lock(registry().mutex);
  return *owned_state(owner, handle)->second.state;
}

void free_state(const Instance& owner, const void* handle) {
  std::unique_ptr<SavedState> gone;
  std::lock_guard lock(registry().mutex);
  const auto it = owned_state(owner, handle);
  gone = std::move(it->second.state);
  registry().states.erase(it);
}

}  // namespace grains::fmu
