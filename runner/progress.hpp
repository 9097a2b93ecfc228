// Progress line for long runs: fraction done, rate in particle-steps per second, ETA.
// On a terminal it redraws one line; otherwise (CI, logs) it prints a line every 10 s.
#pragma once
#include <chrono>
#include <cstdio>

namespace grains {

class Progress {
 public:
  Progress(long total_steps, std::size_t particles);
  void update(long steps_done);
  void finish();
  double elapsed_seconds() const;

 private:
  using clock = std::chrono::steady_clock;
  long total_;
  std::size_t particles_;
  clock::time_point start_, last_;
  bool tty_, shown_ = false;
};

}  // namespace grains
