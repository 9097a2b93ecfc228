#include "worker_pool.hpp"

#include <dlfcn.h>
#include <omp.h>
#include <pthread.h>

#include <mutex>

#include "resource_location.hpp"

namespace grains::fmu {
namespace {
// Beside the FMU binary; its SONAME is its file name (fmu/fork_guard.cpp).
constexpr const char* fork_guard_file = "grains_fork_guard.so";

void release_before_fork() { release_worker_pool(); }

// The fork handler lives in grains_fork_guard.so, which is never unloaded: glibc drops a library's handlers when the
// library is unloaded, and fmpy unloads this one at every free, while a host thread that stepped an instance another
// thread freed keeps its pool. One guard serves the process: an FMU extracted again finds the first by its SONAME.
bool load_fork_guard() {
  if (dlopen(fork_guard_file, RTLD_NOW | RTLD_NOLOAD)) return true;
  return dlopen((binary_directory() / fork_guard_file).c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE) != nullptr;
}
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
    // them forever. Released before the fork, the pool is started anew on either side. Without the guard (removed
    // from the FMU's folder), a handler of this library's own covers the forks while it is loaded.
    if (!load_fork_guard()) pthread_atfork(release_before_fork, nullptr, nullptr);
  });
}

}  // namespace grains::fmu
