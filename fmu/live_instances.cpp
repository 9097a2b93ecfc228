#include "live_instances.hpp"

#include <omp.h>

#include <mutex>
#include <unordered_set>

namespace grains::fmu {
namespace {
// Instances may be created and freed from several host threads at once. Never destroyed, so that a
// host freeing its instances while the process exits still finds it.
struct Registry {
  std::mutex mutex;
  std::unordered_set<const void*> live;
};
Registry& registry() {
  static auto* r = new Registry;
  return *r;
}
}  // namespace

Instance* hand_out(std::unique_ptr<Instance> instance) {
  if (!instance) return nullptr;
  std::lock_guard lock(registry().mutex);
  registry().live.insert(instance.get());
  return instance.release();
}

Instance* live_instance(const void* pointer) {
  std::lock_guard lock(registry().mutex);
  return registry().live.contains(pointer) ? static_cast<Instance*>(const_cast<void*>(pointer)) : nullptr;
}

void free_instance(const void* pointer) {
  {
    std::lock_guard lock(registry().mutex);
    if (registry().live.erase(pointer) == 0) return;   // freed before, or never ours: nothing to do
  }
  delete static_cast<const Instance*>(pointer);
  // OpenMP's worker pool belongs to the calling host thread (libgomp); release it so no engine
  // thread outlives the instance. Another instance's next step simply starts a new pool.
  omp_pause_resource_all(omp_pause_soft);
}

}  // namespace grains::fmu
