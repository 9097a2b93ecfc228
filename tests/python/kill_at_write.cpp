// Preloaded into a run (LD_PRELOAD) by test_runner_killed_mid_write.py: kills the process with SIGKILL at its
// KILL_AT_WRITE-th pwrite, the call through which HDF5 writes the file. A kill there can fall in the middle of a flush
// of HDF5's metadata, the case that damaged files (a kill between HDF5 calls did not).
#include <dlfcn.h>
#include <signal.h>
#include <sys/types.h>

#include <cstdlib>

extern "C" ssize_t pwrite(int fd, const void* buf, size_t n, off_t at) {
  static long calls = 0;
  static const long kill_at = [] {
    const char* e = std::getenv("KILL_AT_WRITE");
    return e ? std::atol(e) : 0L;
  }();
  if (++calls == kill_at) raise(SIGKILL);
  using Pwrite = ssize_t (*)(int, const void*, size_t, off_t);
  static const auto real = reinterpret_cast<Pwrite>(dlsym(RTLD_NEXT, "pwrite"));
  return real(fd, buf, n, at);
}

extern "C" ssize_t pwrite64(int fd, const void* buf, size_t n, off_t at) { return pwrite(fd, buf, n, at); }
