#include "worker_pool.hpp"

#include <dlfcn.h>
#include <omp.h>
#include <pthread.h>

#include <mutex>

namespace grains::fmu {
namespace {
void release_before_fork() { release_worker_pool(); }
}  // namespace

void release_worker_pool() { omp_pause_resource_all(omp_pause_soft); }

void prepare_worker_pools() {
  static std::once_flag once;
  std::call_once(once, [] {
    // A host thread that stepped an instance another thread freed keeps its workers, waiting inside libgomp. fmpy
    // unloads the FMU library at every free, which unloaded libgomp under them: a thread more per instance, and a
    // crash at the fifth. Kept loaded, libgomp serves the next load with the same pools.
    dlopen("libgomp.so.1", RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
    // fork() copies only the forking thread, not its pool's workers: the child's first parallel region waited for
    // them forever. Released before the fork, the pool is started anew on either side. (glibc removes the handler
    // when the library is unloaded.)
    pthread_atfork(release_before_fork, nullptr, nullptr);
  });
}

}  // namespace grains::fmu
