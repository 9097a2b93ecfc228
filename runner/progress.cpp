#include "progress.hpp"

#include <unistd.h>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

namespace grains {

StatusLine::StatusLine() : start_(clock::now()), last_(start_), tty_(isatty(fileno(stderr))) {}

double StatusLine::elapsed_seconds() const { return std::chrono::duration<double>(clock::now() - start_).count(); }

bool StatusLine::due() const {
  return std::chrono::duration<double>(clock::now() - last_).count() >= (tty_ ? 0.5 : 10.0);
}

void StatusLine::show(const std::string& line) {
  last_ = clock::now();
  // "\x1b[K" erases what a longer line before left; padding to a width wrapped on narrower terminals, where
  // every redraw then started a new line
  if (tty_) fmt::print(stderr, "\r{}\x1b[K", line);
  else fmt::print(stderr, "{}\n", line);
  std::fflush(stderr);
  shown_ = true;
}

void StatusLine::finish() {
  if (tty_ && shown_) fmt::print(stderr, "\n");
  shown_ = false;
}

Progress::Progress(long total_steps, std::size_t particles, long first_step)
    : total_(total_steps), first_(first_step), particles_(particles) {}

void Progress::update(long done) {
  if (done <= first_ || !line_.due()) return;
  const double elapsed = line_.elapsed_seconds();
  const double rate = (done - first_) / elapsed;
  const double eta = (total_ - done) / rate;
  line_.show(fmt::format("[{:5.1f}%] step {}/{}  {:.3g} particle-steps/s  elapsed {:.0f} s  ETA {:.0f} s",
                         100.0 * done / total_, done, total_, rate * particles_, elapsed, eta));
}

std::unique_ptr<Simulation> create_simulation(const Scene& scene, bool show_progress) {
  if (!show_progress) return Simulation::create(scene);
  StatusLine line;
  struct EndLine {   // also when the preparation throws: its error then starts on a line of its own
    StatusLine& line;
    ~EndLine() { line.finish(); }
  } end{line};
  return Simulation::create(scene, [&line](std::string_view task, std::size_t done, std::size_t total) {
    if (line.due())
      line.show(fmt::format("[{:5.1f}%] {}: {} of {} placed  elapsed {:.0f} s", 100.0 * done / total, task, done,
                            total, line.elapsed_seconds()));
  });
}

}  // namespace grains
