// The FMU's fork handler, in a library of its own that is never unloaded (linked with -z nodelete and opened with
// RTLD_NODELETE by the FMU binary, fmu/worker_pool.cpp). glibc drops a library's fork handlers when the library is
// unloaded, and fmpy unloads the FMU binary at every free; a host thread whose OpenMP pool outlived that (it stepped
// an instance another thread freed) then forked a child that waited forever for the pool's workers. Exports nothing.
#include <omp.h>
#include <pthread.h>

namespace {
// fork() copies only the forking thread, not its pool's workers: released before the fork, the pool is started anew
// on either side.
void release_the_forking_threads_pool() { omp_pause_resource_all(omp_pause_soft); }

[[gnu::constructor]] void register_fork_handler() { pthread_atfork(release_the_forking_threads_pool, nullptr, nullptr); }
}  // namespace
