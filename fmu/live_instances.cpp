#include "live_instances.hpp"

#include <omp.h>

#include <cstdint>
#include <map>
#include <mutex>

namespace grains::fmu {
namespace {
// Instances may be created and freed from several host threads at once. Never destroyed, so that a
// host freeing its instances while the process exits still finds it.
struct Registry {
  std::mutex mutex;
  std::map<std::uintptr_t, std::unique_ptr<Instance>> live;
  std::uintptr_t next = 0x1000;   // handles: aligned, never 0, never reused
};
Registry& registry() {
  static auto* r = new Registry;
  return *r;
}
}  // namespace

void* hand_out(std::unique_ptr<Instance> instance) {
  if (!instance) return nullptr;
  std::lock_guard lock(registry().mutex);
  const std::uintptr_t handle = registry().next;
  registry().next += 16;
  registry().live.emplace(handle, std::move(instance));
  return reinterpret_cast<void*>(handle);
}

Instance* live_instance(const void* handle) {
  std::lock_guard lock(registry().mutex);
  const auto it = registry().live.find(reinterpret_cast<std::uintptr_t>(handle));
  return it == registry().live.end() ? nullptr : it->second.get();
}

void free_instance(const void* handle) {
  std::unique_ptr<Instance> gone;
  {
    std::lock_guard lock(registry().mutex);
    const auto it = registry().live.find(reinterpret_cast<std::uintptr_t>(handle));
    if (it == registry().live.end()) return;   // freed before, or never ours: nothing to do
    gone = std::move(it->second);
    registry().live.erase(it);
  }
  gone.reset();   // deleted outside the lock
  // OpenMP's worker pool belongs to the calling host thread (libgomp); release it so no engine
  // thread outlives the instance. Another instance's next step simply starts a new pool.
  omp_pause_resource_all(omp_pause_soft);
}

}  // namespace grains::fmu
