// Pressure control of a periodic orthogonal cell (physics.md section 9): the cell lengths follow the
// CVODE-integrated equations of CellLengthOde under the stress of the last force evaluation, extrapolated
// to the middle of the step; the caller moves the particles affinely by the returned per-axis scale (their
// velocities stay relative to the affine flow).
//
// Why extrapolated: the stress depends on the lengths, and holding the start-of-step stress over the step
// (explicit Euler in the coupling) multiplies an undamped cell oscillation's energy by 1 + (w dt)^2 / 2 at
// every step, a growth of w^2 dt / 4 per unit time that CVODE's tolerances cannot touch (a lattice of
// undamped adhesive disks grew 7 % per cell period at the scenes' step; elastic packings with e >= 0.95
// lost every contact). Held at s_n + (s_n - s_{n-1}) h_n / (2 h_{n-1}), the midpoint value of the line
// through the last two stresses, the growth per step is of order (w dt)^4 (3e-8 instead of 1.2e-4 at
// w dt = 0.022). The first step after a restart from rest or a hold has no previous stress and holds s_n.
//
// Saved states: CVODE's internal history (order, step size, Nordsieck array) cannot be serialised, so a
// state carries what built it instead: the (L, dL/dt, t) of CVODE's last restart and the advances since,
// with their forcing. Restoring restarts there and replays them, which rebuilds the history bit for bit:
// saving changes nothing (a host may take states at will), and a restored run continues bit-identically
// with the run that saved it. CVODE restarts every replay_limit advances, which bounds what a state carries.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "analysis/stress.hpp"
#include "cell/cell_length_ode.hpp"
#include "core/byte_stream.hpp"

namespace grains {

template <int D>
class Barostat {
 public:
  Barostat(const CellLengthParameters& p, const Vec<D>& length, double target_pressure, double t)
      : ode_(p), length_(length), rate_(Vec<D>::Zero()), target_(target_pressure), advanced_target_(target_pressure),
        advanced_cap_(p.rate_cap) {
    restart(t);
  }

  // Restart CVODE at every particle step (for measuring what its kept history saves).
  void restart_every_step(bool on) { restart_every_step_ = on; }
  double target_pressure() const { return target_; }
  // A new target (and the strain-rate cap that goes with it) is a discontinuity of the forcing:
  // CVODE restarts at the next step.
  // Judged against the forcing CVODE last integrated with, not against earlier calls between two steps: a
  // programme continued from a saved state that sets its stage's target and then the ramp's, as before the
  // save, makes no discontinuity (and no restart the unbroken run did not make). A change within a few
  // roundings is none either: fmpy interpolates a constant input as 0.01 at most points and one ulp off at
  // others, and each such ulp had restarted CVODE (213 restarts in 12,000 steps at h = 7 dt, 24 at h = 2000 dt).
  void set_target_pressure(double p, double rate_cap) {
    target_changed_ = !within_rounding(p, advanced_target_) || !within_rounding(rate_cap, advanced_cap_);
    follow_target_pressure(p, rate_cap);
  }
  // A target that moves a little every step (a ramp): like the stress, part of the forcing CVODE follows
  // with its history kept.
  void follow_target_pressure(double p, double rate_cap) {
    target_ = p;
    ode_.set_rate_cap(rate_cap);
  }
  // Held: the cell stops and stays at rest (the caller stops advancing it); released: CVODE restarts
  // from rest at the next advance.
  void hold() { rate_.setZero(), reset_pending_ = true; }
  void release() { reset_pending_ = true; }
  const Vec<D>& length() const { return length_; }
  // dL/dt (within the strain-rate cap).
  Vec<D> rate() const {
    Vec<D> r;
    const double cap = ode_.parameters().rate_cap;
    for (int a = 0; a < D; ++a) r[a] = std::clamp(rate_[a], -cap * length_[a], cap * length_[a]);
    return r;
  }
  CellLengthStatistics statistics() const { return ode_.statistics(); }
  const CellLengthParameters& parameters() const { return ode_.parameters(); }

  // The contacts' damping of the cell's strain rate (see affine_contact_damping), per axis.
  void set_contact_damping(const Vec<D>& eta) { ode_.set_extra_damping(eta.data()); }
  Vec<D> contact_damping() const {
    Vec<D> eta;
    for (int a = 0; a < D; ++a) eta[a] = ode_.extra_damping(a);
    return eta;
  }

  // Advance the lengths over [t, t_end] under `stress` (frozen); returns L(t_end) / L(t) per axis. The next
  // advance continues CVODE's history if it starts at this one's t_end exactly.
  Vec<D> advance(double t, double t_end, const Tensor<D>& stress) {
    if (reset_pending_ || target_changed_ || restart_every_step_ || ode_.time() != t || since_restart_.size() >= replay_limit)
      restart(t);
    target_changed_ = false, advanced_target_ = target_, advanced_cap_ = ode_.parameters().rate_cap;
    const double h = t_end - t;
    // The previous advance ended here and was not much shorter than this one (a host's tiny remainder step
    // would turn stress noise into a steep line): extrapolate; else hold.
    const bool extrapolate = previous_.valid && previous_.t_end == t && 2 * previous_.step >= h;
    Vec<D> excess;
    for (int a = 0; a < D; ++a) {
      const double now = stress(a, a);
      const double mid = extrapolate ? now + (now - previous_.stress[a]) * (h / (2 * previous_.step)) : now;
      excess[a] = mid - target_;
      previous_.stress[a] = now;
    }
    previous_.t_end = t_end, previous_.step = h, previous_.valid = true;
    ode_.advance(t_end, excess.data());
    Advance done{t_end, ode_.parameters().rate_cap, {}, {}};
    for (int a = 0; a < D; ++a) done.excess[a] = excess[a], done.extra_damping[a] = ode_.extra_damping(a);
    since_restart_.push_back(done);
    const Vec<D> before = length_;
    for (int a = 0; a < D; ++a) length_[a] = ode_.length(a), rate_[a] = ode_.state_rate(a);
    return length_.cwiseQuotient(before);
  }

  void save(ByteWriter& w) const {
    w.put(length_), w.put(rate_), w.put(target_), w.put(reset_pending_), w.put(target_changed_), w.put(advanced_target_),
        w.put(advanced_cap_);
    w.put(restart_), w.put_vector(since_restart_), w.put(ode_.statistics());
    w.put(previous_);
    // The rates' tolerance unit, from the start pressure of the run that saved (a host may start another instance at
    // another pressure and restore this state there: the history replays, and the run continues, only with it).
    w.put(ode_.parameters().time_unit);
  }
  void load(ByteReader& r) {
    length_ = r.get<Vec<D>>(), rate_ = r.get<Vec<D>>(), target_ = r.get<double>(), reset_pending_ = r.get<bool>();
    target_changed_ = r.get<bool>(), advanced_target_ = r.get<double>(), advanced_cap_ = r.get<double>();
    restart_ = r.get<Restart>(), r.get_vector(since_restart_);
    const auto statistics = r.get<CellLengthStatistics>();
    previous_ = r.get<Previous>();
    const double time_unit = r.get<double>();
    if (!(std::isfinite(time_unit) && time_unit > 0))
      throw std::runtime_error(fmt::format("the saved barostat's time unit is {}: a finite number > 0", time_unit));
    ode_.set_time_unit(time_unit);
    if (since_restart_.size() > replay_limit) throw std::runtime_error("saved barostat history is longer than this build keeps");
    check_loaded(statistics);   // before the replay: a negative cap or length reached std::clamp with its bounds reversed
    // Replayed with the forcing each advance had; the last advance's damping and cap stay, as they did.
    const Vec<D> damping = contact_damping();
    const double cap = ode_.parameters().rate_cap;
    ode_.reset(restart_.length, restart_.rate, restart_.t);
    for (const Advance& a : since_restart_) {
      ode_.set_extra_damping(a.extra_damping);
      ode_.set_rate_cap(a.rate_cap);
      ode_.advance(a.t_end, a.excess);
    }
    if (since_restart_.empty()) ode_.set_extra_damping(damping.data()), ode_.set_rate_cap(cap);
    // A cell held since its last advance has its rate zeroed by hold(), not by CVODE: the next advance restarts
    // from it (reset_pending_), so only the lengths must be the history's (a host that held a moving cell and
    // then saved had its state refused).
    for (int a = 0; a < D; ++a)
      if (!since_restart_.empty() && (ode_.length(a) != length_[a] || (!reset_pending_ && ode_.state_rate(a) != rate_[a])))
        throw std::runtime_error("saved barostat history does not lead to the saved cell lengths");
    ode_.set_statistics(statistics);
  }

 private:
  // CVODE's last restart and the advances since (see the header comment). Plain arrays: no padding bytes
  // (an Eigen 2-vector is aligned to 16), so a saved state is the same bytes for the same run.
  struct Restart {
    double length[D], rate[D], t;
  };
  struct Advance {
    double t_end, rate_cap, excess[D], extra_damping[D];
  };
  // The last advance's diagonal stress, end and length: the line the next one extrapolates along.
  struct Previous {
    double stress[D], t_end, step;
    std::uint64_t valid;   // a word, not a bool: no padding bytes in a saved state
  };
  static constexpr std::size_t replay_limit = 500;
  // What a run can have saved (found by fuzzing: a negative strain-rate cap in the history was replayed as it was).
  void check_loaded(const CellLengthStatistics& statistics) const {
    const auto refuse = [](const std::string& field, double value, const char* allowed) {
      throw std::runtime_error(fmt::format("the saved barostat's {} is {}: {}", field, value, allowed));
    };
    const auto length = [&](const std::string& field, double v) {
      if (!(std::isfinite(v) && v > 0)) refuse(field, v, "a finite number > 0");
    };
    const auto finite = [&](const std::string& field, double v) {
      if (!std::isfinite(v)) refuse(field, v, "a finite number");
    };
    const auto cap = [&](const std::string& field, double v) {
      if (!(v >= 0)) refuse(field, v, "a number >= 0");
    };
    for (int a = 0; a < D; ++a) {
      length(fmt::format("cell length on axis {}", a), length_[a]);
      finite(fmt::format("rate on axis {}", a), rate_[a]);
      length(fmt::format("restart's cell length on axis {}", a), restart_.length[a]);
      finite(fmt::format("restart's rate on axis {}", a), restart_.rate[a]);
      finite(fmt::format("last stress on axis {}", a), previous_.stress[a]);
    }
    finite("target pressure", target_), finite("last advance's target pressure", advanced_target_);
    cap("last advance's strain-rate cap", advanced_cap_);
    finite("restart's time", restart_.t), finite("last advance's end", previous_.t_end);
    finite("last advance's step", previous_.step);
    if (previous_.valid > 1) refuse("last stress's flag", double(previous_.valid), "0 or 1");
    for (std::size_t k = 0; k < since_restart_.size(); ++k) {
      const Advance& x = since_restart_[k];
      finite(fmt::format("end of advance {}", k), x.t_end);
      cap(fmt::format("strain-rate cap of advance {}", k), x.rate_cap);
      for (int a = 0; a < D; ++a) {
        finite(fmt::format("stress excess of advance {} on axis {}", k, a), x.excess[a]);
        if (!(std::isfinite(x.extra_damping[a]) && x.extra_damping[a] >= 0))
          refuse(fmt::format("contact damping of advance {} on axis {}", k, a), x.extra_damping[a], "a finite number >= 0");
      }
    }
    // CVODE's counters are added to these: a count far beyond any run's would overflow the sums.
    for (const auto& [name, n] : {std::pair{"CVODE step count", statistics.internal_steps},
                                  std::pair{"CVODE right-hand-side count", statistics.rhs_evaluations},
                                  std::pair{"CVODE restart count", statistics.reinitialisations}})
      if (n < 0 || n > (1L << 62)) refuse(name, double(n), "a count from 0 to 2^62");
  }
  static bool within_rounding(double a, double b) {
    return std::abs(a - b) <= 4 * std::numeric_limits<double>::epsilon() * std::max(std::abs(a), std::abs(b));
  }
  void restart(double t) {
    ode_.reset(length_.data(), rate_.data(), t);
    restart_ = Restart{};
    for (int a = 0; a < D; ++a) restart_.length[a] = length_[a], restart_.rate[a] = rate_[a];
    restart_.t = t;
    since_restart_.clear();
    reset_pending_ = false;
  }

 private:
  CellLengthOde ode_;
  Vec<D> length_, rate_;   // rate_: CVODE's rate variable, what a restart starts from
  double target_;
  bool reset_pending_ = false;    // a held cell released (or held): CVODE restarts at the next advance
  bool target_changed_ = false;   // set_target_pressure moved the forcing from what CVODE last integrated
  double advanced_target_, advanced_cap_;   // ... which was this
  bool restart_every_step_ = false;
  Restart restart_{};
  std::vector<Advance> since_restart_;
  Previous previous_{};
};

}  // namespace grains
