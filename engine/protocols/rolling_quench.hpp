// The consolidation programme's quench of rolling mechanisms (README, consolidation). A loose cohesive
// network keeps soft, prestress-held rolling mechanisms that neither the normal nor the tangential
// dashpot sees, so the paper's law alone leaves net forces far above the equilibrium threshold. Each
// stage therefore runs the paper's law (rolling dashpot beta = 0) until the sample has settled -- its
// kinetic and stress equilibrium ratios below settle_ratio for settle_checks checks in a row, with the
// solid fraction steady to settle_compaction over them -- and
// only then switches the rolling dashpot on: switched on earlier it slows the rearrangements and lowers
// the packing fraction. Once the four criteria hold it is switched off again, and the stage counts as
// in equilibrium only if they still hold at the next check with beta = 0: an equilibrium of the
// paper's law, whose relative spins (what the dashpot acts on) have died out.
// All state but the counters lives in the Simulation (the tunable parameter rolling.damping_ratio).
#pragma once
#include <cmath>

#include "core/simulation.hpp"

namespace grains {

// beta is small on purpose: a large one (0.1-1) overdamps the soft mechanisms (c_r / (I omega) >> 1 at their
// omega ~ 4-11 / T0), which then creep towards equilibrium instead of reaching it; the criteria pass while
// the dashpot holds the creeping spins, and fail as soon as it is switched off (README, consolidation).
struct QuenchSettings {
  double damping = 0.003;      // beta while quenching; 0: no quench (the paper's law throughout)
  double settle_ratio = 100;   // the kinetic and stress ratios below which a stage has settled
  long settle_checks = 20;     // consecutive checks they must stay below it
  // ... while the solid fraction moves by less than this (relative) over those checks: a loose network
  // collapses slowly at its target pressure, with the kinetic and stress ratios already small.
  double settle_compaction = 1e-5;
};

class RollingQuench {
 public:
  // Starts a stage on the paper's law.
  RollingQuench(Simulation& s, const QuenchSettings& q) : s_(s), q_(q) { switch_dashpot(false); }

  // At an equilibrium check, `steps` into the stage: whether the stage is in equilibrium with beta = 0.
  bool in_equilibrium(long steps) {
    const bool equilibrium = s_.get("equilibrium") == 1.0;
    if (on_) {   // quenched: switch off and let the next check judge the paper's law
      if (equilibrium) switch_dashpot(false);
      return false;
    }
    if (equilibrium) return true;
    const bool quiet = s_.get("equilibrium_kinetic") < q_.settle_ratio && s_.get("equilibrium_stress") < q_.settle_ratio;
    const double phi = s_.get("solid_fraction");
    if (!quiet) settled_checks_ = 0;
    else if (settled_checks_ == 0 || std::abs(phi - run_phi_) > q_.settle_compaction * run_phi_)
      settled_checks_ = 1, run_phi_ = phi;   // a settled run starts here (or starts again: still compacting)
    else ++settled_checks_;
    if (q_.damping > 0 && settled_checks_ >= q_.settle_checks) {
      switch_dashpot(true);
      if (start_ < 0) start_ = steps;
    }
    return false;
  }

  // Leaves the paper's law for whatever follows the stage.
  void end() { switch_dashpot(false); }

  long start() const { return start_; }   // steps into the stage at the first switch-on; -1: never
  bool on() const { return on_; }

 private:
  void switch_dashpot(bool on) {
    if (q_.damping <= 0) return;   // no quench: the scene's rolling.damping_ratio is left alone
    s_.set("rolling.damping_ratio", on ? q_.damping : 0.0);
    on_ = on;
    settled_checks_ = 0;
  }

  Simulation& s_;
  QuenchSettings q_;
  bool on_ = false;
  long settled_checks_ = 0;
  double run_phi_ = 0;   // the solid fraction at the start of the settled run
  long start_ = -1;
};

}  // namespace grains
