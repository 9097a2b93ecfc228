#include "progress.hpp"

#include <unistd.h>

#include <fmt/format.h>

namespace grains {

Progress::Progress(long total_steps, std::size_t particles)
    : total_(total_steps), particles_(particles), start_(clock::now()), last_(start_), tty_(isatty(fileno(stderr))) {}

double Progress::elapsed_seconds() const { return std::chrono::duration<double>(clock::now() - start_).count(); }

void Progress::update(long done) {
  auto now = clock::now();
  const double since = std::chrono::duration<double>(now - last_).count();
  if (since < (tty_ ? 0.5 : 10.0) || done <= 0) return;
  last_ = now;
  const double elapsed = elapsed_seconds();
  const double rate = done / elapsed;
  const double eta = (total_ - done) / rate;
  std::string line = fmt::format("[{:5.1f}%] step {}/{}  {:.3g} particle-steps/s  elapsed {:.0f} s  ETA {:.0f} s",
                                 100.0 * done / total_, done, total_, rate * particles_, elapsed, eta);
  if (tty_) fmt::print(stderr, "\r{:<90}", line);
  else fmt::print(stderr, "{}\n", line);
  shown_ = true;
}

void Progress::finish() {
  if (tty_ && shown_) fmt::print(stderr, "\n");
}

}  // namespace grains
