// Progress for long runs. A status line on stderr: on a terminal it redraws one line at most twice a
// second; otherwise (CI, logs) it prints a line every 10 s. Progress adds the fraction done, the rate in
// particle-steps per second and the ETA for a run of known length.
#pragma once
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

namespace grains {

class StatusLine {
 public:
  StatusLine();
  bool due() const;                     // time for another line
  void show(const std::string& line);   // print it (and restart the interval)
  void finish();                        // end a redrawn line
  double elapsed_seconds() const;

 private:
  using clock = std::chrono::steady_clock;
  clock::time_point start_, last_;
  bool tty_, shown_ = false;
};

class Progress {
 public:
  // A resumed run starts at `first_step`: the rate and ETA count the steps from there.
  Progress(long total_steps, std::size_t particles, long first_step = 0);
  void update(long steps_done);
  void finish() { line_.finish(); }
  double elapsed_seconds() const { return line_.elapsed_seconds(); }

 private:
  long total_, first_;
  std::size_t particles_;
  StatusLine line_;
};

class Scene;
class Simulation;

// Simulation::create, with a status line while a long preparation runs (random insertion of many particles: a
// minute or two for 10^6) where `show_progress`; shown once it has taken half a second (10 s in a log).
std::unique_ptr<Simulation> create_simulation(const Scene& scene, bool show_progress);

}  // namespace grains
