// The child that reads a file before `grains resume` does (see resume_probe.hpp). A separate process, since a signal
// inside HDF5 leaves nothing to recover in the process it hits: HDF5's state is then undefined, and the damaged
// header is decoded by HDF5's own code, before any API call returns something a check could look at.
#include "resume_probe.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <stdexcept>
#include <string_view>

#include <fcntl.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include "io/h5md_resume_reads.hpp"

namespace grains {

namespace {

std::string signal_name(int signal) {
  switch (signal) {
    case SIGSEGV: return "SIGSEGV";
    case SIGFPE: return "SIGFPE";
    case SIGBUS: return "SIGBUS";
    case SIGABRT: return "SIGABRT";
    case SIGILL: return "SIGILL";
    case SIGKILL: return "SIGKILL";
    case SIGTERM: return "SIGTERM";
    case SIGINT: return "SIGINT";
    default: return fmt::format("signal {}", signal);
  }
}

bool is_crash(int signal) {
  return signal == SIGSEGV || signal == SIGFPE || signal == SIGBUS || signal == SIGABRT || signal == SIGILL ||
         signal == SIGTRAP || signal == SIGSYS;
}

// What the child is reading, for the parent's message: a page both processes share, which the child writes before
// each read (a copy into memory, no system call) and the parent reads once the child has ended. Empty where the
// page could not be had.
class ReadingNow {
 public:
  ReadingNow() {
    void* page = ::mmap(nullptr, kBytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
    if (page != MAP_FAILED) text_ = static_cast<char*>(page);
  }
  ~ReadingNow() {
    if (text_) ::munmap(text_, kBytes);
  }
  ReadingNow(const ReadingNow&) = delete;
  ReadingNow& operator=(const ReadingNow&) = delete;

  void set(std::string_view what) noexcept {
    if (!text_) return;
    const std::size_t n = std::min(what.size(), kBytes - 1);
    std::memcpy(text_, what.data(), n);
    text_[n] = '\0';
  }
  // " reading WHAT", or "" before the child told anything.
  std::string reading() const {
    if (!text_ || !text_[0]) return "";
    return " reading " + std::string(text_, ::strnlen(text_, kBytes));
  }

 private:
  static constexpr std::size_t kBytes = 4096;
  char* text_ = nullptr;
};

// Reads the file and ends, telling `now` what it reads before each read and writing a byte to `progress` when a
// second has passed since the last.
[[noreturn]] void read_in_child(const std::string& path, pid_t parent, int progress, ReadingNow& now) {
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);   // a resume killed while the child reads takes the child with it
  if (::getppid() != parent) ::_exit(0);
  if (const int null = ::open("/dev/null", O_WRONLY); null >= 0) {   // the parent's message is the report
    ::dup2(null, STDOUT_FILENO);
    ::dup2(null, STDERR_FILENO);
  }
  auto last = std::chrono::steady_clock::now();
  read_what_a_resume_reads(path, [&](const std::string& what) {
    now.set(what);
    if (std::chrono::steady_clock::now() - last < std::chrono::seconds(1)) return;
    last = std::chrono::steady_clock::now();
    const char read = 1;
    [[maybe_unused]] const ssize_t written = ::write(progress, &read, 1);
  });
  ::_exit(0);   // not exit(): the parent's exit handlers and buffered output are the parent's
}

// Waits for the child to end (its end closes the pipe's only write end) while it tells of an object read at least
// every `object_limit`. Whether it ended; false: it is stuck.
bool wait_for_end(int progress, std::chrono::seconds object_limit) {
  for (;;) {
    pollfd read_one{progress, POLLIN, 0};
    const int ready = ::poll(&read_one, 1, int(std::chrono::milliseconds(object_limit).count()));
    if (ready == 0) return false;
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) return true;   // cannot watch it: waitpid below waits for its end
    char bytes[4096];
    const ssize_t got = ::read(progress, bytes, sizeof bytes);
    if (got == 0 || (got < 0 && errno != EINTR)) return true;   // the end of the pipe: the child has ended
  }
}

}  // namespace

void refuse_a_file_hdf5_dies_reading(const std::string& path, std::chrono::seconds object_limit) {
  int pipe_ends[2];
  if (::pipe2(pipe_ends, O_CLOEXEC) != 0) return;   // no child: the resume reads the file as it always did
  ReadingNow now;
  const pid_t parent = ::getpid();
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(pipe_ends[0]);
    read_in_child(path, parent, pipe_ends[1], now);
  }
  ::close(pipe_ends[1]);
  if (child < 0) {   // no child: the resume reads the file as it always did
    ::close(pipe_ends[0]);
    return;
  }
  const bool ended = wait_for_end(pipe_ends[0], object_limit);
  if (!ended) ::kill(child, SIGKILL);
  ::close(pipe_ends[0]);
  int status = 0;
  pid_t waited;
  while ((waited = ::waitpid(child, &status, 0)) < 0 && errno == EINTR) {
  }
  // The child has ended, or been killed and waited for: what it last told stays as it was.
  const std::string reading = now.reading();
  if (!ended)
    throw std::runtime_error(fmt::format("'{}': HDF5 was still{} after {} s (a damaged header can make it loop without "
                                         "end): the file is damaged; not resumed", path,
                                         reading.empty() ? " reading one object of it" : reading, object_limit.count()));
  if (waited != child) return;   // its status is lost (SIGCHLD ignored): the resume goes on as it always did
  if (WIFSIGNALED(status) && is_crash(WTERMSIG(status)))
    throw std::runtime_error(fmt::format("'{}': HDF5 crashed ({}){}: the file is damaged; not resumed", path,
                                         signal_name(WTERMSIG(status)), reading.empty() ? " reading it" : reading));
  if (WIFSIGNALED(status))
    throw std::runtime_error(fmt::format("'{}': the process that reads it before the resume was ended by {}{}: not "
                                         "resumed", path, signal_name(WTERMSIG(status)),
                                         reading.empty() ? "" : " while" + reading));
  if (WIFEXITED(status) && WEXITSTATUS(status) != 0)   // a sanitizer's report, say
    throw std::runtime_error(fmt::format("'{}': the process that reads it before the resume ended with status {}{}: the "
                                         "file may be damaged; not resumed", path, WEXITSTATUS(status),
                                         reading.empty() ? "" : " after" + reading));
}

}  // namespace grains
