// The quench's drag, stepped down when it holds a stage back (docs/history/speed-and-reproduction-log.md: the drag quench).
// A drag damps the slow modes a loose network rings with, and their forces fall; but a network that
// still creeps towards a denser state creeps at the speed the drag allows, its largest net force then
// steady near the drag's own gamma m v. So while a stage is quenched the smallest force ratio of each
// window of `patience` checks is compared with the previous window's: if it has not fallen by a fifth,
// the drag halves, down to `floor` (gamma T values). After a change the next window only records.
// A window of 100,000 steps tells the two apart: a creep at seed 4's P* = 0.0178 held the force ratio
// near 20 for a million steps, while stages with rolling resistance that converge under the drag
// lose a third or more per window; the first version (halving required within 30,000 steps) stepped
// those down too, and three of them then missed their budgets.
#pragma once
#include <algorithm>
#include <array>
#include <limits>

namespace grains {

class DragSchedule {
 public:
  // patience 0: the drag never changes.
  DragSchedule(double start, double floor, long patience)
      : value_(start), floor_(std::min(floor, start)), patience_(patience) {}

  double value() const { return value_; }

  // One check while quenched, with its force ratio (largest net force over the threshold). True when
  // the drag has just stepped down.
  bool observe(double force_ratio) {
    best_ = std::min(best_, force_ratio);
    if (patience_ <= 0 || ++checks_ < patience_) return false;
    const bool stalled = best_ > 0.8 * previous_best_;   // false after a change: previous_best_ is infinite
    previous_best_ = best_, best_ = none(), checks_ = 0;
    if (!stalled || value_ <= floor_) return false;
    value_ = std::max(floor_, 0.5 * value_);
    previous_best_ = none();
    return true;
  }

  // The quench was switched off: a new quench starts new windows (at the drag reached so far).
  void restart() { best_ = previous_best_ = none(), checks_ = 0; }

  // Where the schedule stands (a programme's checkpoint between two checks), and back.
  std::array<double, 4> progress() const { return {value_, double(checks_), best_, previous_best_}; }
  void resume(const std::array<double, 4>& p) { value_ = p[0], checks_ = long(p[1]), best_ = p[2], previous_best_ = p[3]; }

 private:
  static double none() { return std::numeric_limits<double>::infinity(); }
  double value_, floor_;
  long patience_;
  long checks_ = 0;
  double best_ = none(), previous_best_ = none();
};

}  // namespace grains
