// The consolidation programme's quench of settled stages (docs/history/speed-and-reproduction-log.md: the rolling quench, the drag quench). The paper's law
// damps relative normal motion only, so a loose cohesive network keeps slow collective modes -- its
// softest elastic modes, grains and branches swinging about single contacts, rolling mechanisms --
// that ring for thousands of T with net forces far above the equilibrium threshold. Each stage
// therefore runs the paper's law until the sample has settled -- its kinetic and stress equilibrium
// ratios below settle_ratio for settle_checks checks in a row, with the solid fraction steady to
// settle_compaction over them -- and only then switches on a drag on every grain (drag.rate), and
// optionally the rolling dashpot (rolling.damping_ratio): switched on earlier they would slow the
// rearrangements and change the packing. Once the four criteria hold both are switched off again,
// and the stage counts as in equilibrium only if they then hold at confirm_checks checks in a row
// without them: an equilibrium of the paper's law. While quenched, the drag steps down when it holds
// a creeping stage back (drag_schedule.hpp). A background drag (programme.background_drag), if asked
// for, acts beneath the quench from the stage's start: the quench raises the drag and returns it there,
// and the confirming checks run with it (at rest it exerts no force).
// All state but the counters lives in the Simulation (its tunable parameters).
#pragma once
#include <cmath>
#include <stdexcept>
#include <vector>

#include "core/simulation.hpp"
#include "protocols/drag_schedule.hpp"

namespace grains {

struct QuenchSettings {
  // gamma T of the drag, T the output inertial_time: about critical for the slow modes (periods of
  // 5-40 T); a stage of seed 4 at P* = 0.01 that the rolling dashpot alone left ringing for 7 million
  // steps reached equilibrium 300,000 steps into the quench with gamma T = 0.5 or 2. 0: no drag.
  double drag = 1.0;
  double background = 0.0;   // gamma T of the drag while the quench is off (0: none; the programme's stages under pressure)
  double drag_min = 0.125;   // the drag steps down to this (gamma T) while it holds a creep back ...
  long patience = 1000;      // ... judged over windows of this many checks (0: never)
  // beta of the rolling dashpot, on top of the drag (the quench of earlier versions); 0: not used.
  double damping = 0.0;
  double settle_ratio = 100;   // the kinetic and stress ratios below which a stage has settled
  long settle_checks = 20;     // consecutive checks they must stay below it
  // ... while the solid fraction moves by less than this (relative) over those checks: a loose network
  // collapses slowly at its target pressure, with the kinetic and stress ratios already small.
  double settle_compaction = 1e-5;
  long confirm_checks = 5;     // consecutive checks the criteria must hold for the stage to be in equilibrium

  bool any() const { return drag > 0 || damping > 0; }
};

class StageQuench {
 public:
  // Starts a stage on the paper's law.
  StageQuench(Simulation& s, const QuenchSettings& q) : s_(s), q_(q), drag_(q.drag, q.drag_min, q.patience) {
    switch_quench(false);
  }

  // At an equilibrium check, `steps` into the stage: whether the stage is in equilibrium without the
  // quench, i.e. the criteria have held at confirm_checks checks in a row (single checks sample the
  // phase of whatever still rings: a drag-quenched state whose forces pass once may read 3-4 times the
  // threshold 200 steps later, as a contact-scale mode swings back).
  bool in_equilibrium(long steps) {
    const bool equilibrium = s_.get("equilibrium") == 1.0;
    if (on_) {   // quenched: switch off and let the next checks judge the paper's law
      if (equilibrium) switch_quench(false);
      else if (drag_.observe(s_.get("equilibrium_force"))) switch_quench(true);   // at the lower drag
      return false;
    }
    if (equilibrium) return ++confirmed_ >= q_.confirm_checks;
    confirmed_ = 0;
    const bool quiet = s_.get("equilibrium_kinetic") < q_.settle_ratio && s_.get("equilibrium_stress") < q_.settle_ratio;
    const double phi = s_.get("solid_fraction");
    if (!quiet) settled_checks_ = 0;
    else if (settled_checks_ == 0 || std::abs(phi - run_phi_) > q_.settle_compaction * run_phi_)
      settled_checks_ = 1, run_phi_ = phi;   // a settled run starts here (or starts again: still compacting)
    else ++settled_checks_;
    if (q_.any() && settled_checks_ >= q_.settle_checks) {
      switch_quench(true);
      if (start_ < 0) start_ = steps;
    }
    return false;
  }

  // Leaves the paper's law (and the background drag) for whatever follows the stage.
  void end() {
    switch_quench(false);
    if (q_.background > 0) s_.set("drag.rate", 0.0);
  }

  // Where the quench stands between two checks, for a programme's checkpoint; resume() continues a quench
  // built anew for the same stage from it (the simulation restored to the same step).
  std::vector<double> progress() const {
    const auto d = drag_.progress();
    return {double(on_), double(settled_checks_), double(confirmed_), run_phi_, double(start_), d[0], d[1], d[2], d[3]};
  }
  void resume(const std::vector<double>& p) {
    if (p.size() != 9) throw std::invalid_argument("a stage quench's progress has 9 numbers");
    on_ = p[0] != 0, settled_checks_ = long(p[1]), confirmed_ = long(p[2]), run_phi_ = p[3], start_ = long(p[4]);
    drag_.resume({p[5], p[6], p[7], p[8]});
    apply(on_);
  }

  long start() const { return start_; }   // steps into the stage at the first switch-on; -1: never
  bool on() const { return on_; }
  double drag() const { return drag_.value(); }   // gamma T of the drag now (stepped down, or as set)

 private:
  // What is not used is left alone: the scene's own drag.rate or rolling.damping_ratio then stays.
  void switch_quench(bool on) {
    apply(on);
    if (!on) drag_.restart();
    on_ = on && q_.any();
    settled_checks_ = 0, confirmed_ = 0;
  }
  // The simulation's drag and rolling dashpot as the quench on or off asks.
  void apply(bool on) {
    if (q_.drag > 0 || q_.background > 0)
      s_.set("drag.rate", (on && q_.drag > 0 ? drag_.value() : q_.background) / s_.get("inertial_time"));
    if (q_.damping > 0) s_.set("rolling.damping_ratio", on ? q_.damping : 0.0);
  }

  Simulation& s_;
  QuenchSettings q_;
  DragSchedule drag_;
  bool on_ = false;
  long settled_checks_ = 0;
  long confirmed_ = 0;   // consecutive checks in equilibrium without the quench
  double run_phi_ = 0;   // the solid fraction at the start of the settled run
  long start_ = -1;
};

}  // namespace grains
