// Pressure control of a periodic orthogonal cell (physics.md section 9): the cell lengths follow the
// CVODE-integrated equations of CellLengthOde under the stress of the last force evaluation; the
// caller moves the particles affinely by the returned per-axis scale (their velocities stay relative
// to the affine flow).
//
// Saved states: CVODE's internal history cannot be serialised, so saving marks a re-initialisation at
// the next step, and restoring does the same: both paths restart CVODE from the same (L, dL/dt), and a
// run restored from a state continues bit-identically with the run that saved it.
#pragma once
#include <algorithm>

#include "analysis/stress.hpp"
#include "cell/cell_length_ode.hpp"
#include "core/byte_stream.hpp"

namespace grains {

template <int D>
class Barostat {
 public:
  Barostat(const CellLengthParameters& p, const Vec<D>& length, double target_pressure, double t)
      : ode_(p), length_(length), rate_(Vec<D>::Zero()), target_(target_pressure) {
    ode_.reset(length_.data(), rate_.data(), t);
  }

  // Restart CVODE at every particle step (for measuring what its kept history saves).
  void restart_every_step(bool on) { restart_every_step_ = on; }
  double target_pressure() const { return target_; }
  // A new target (and the strain-rate cap that goes with it) is a discontinuity of the forcing:
  // CVODE restarts at the next step.
  void set_target_pressure(double p, double rate_cap) {
    if (p != target_ || rate_cap != ode_.parameters().rate_cap) reset_pending_ = true;
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

  // The contacts' damping of the cell's strain rate (see affine_contact_damping), per axis.
  void set_contact_damping(const Vec<D>& eta) { ode_.set_extra_damping(eta.data()); }
  Vec<D> contact_damping() const {
    Vec<D> eta;
    for (int a = 0; a < D; ++a) eta[a] = ode_.extra_damping(a);
    return eta;
  }

  // Advance the lengths over [t, t + h] under `stress` (frozen); returns L(t + h) / L(t) per axis.
  Vec<D> advance(double t, double h, const Tensor<D>& stress) {
    if (reset_pending_ || restart_every_step_ || ode_.time() != t) ode_.reset(length_.data(), rate_.data(), t);
    reset_pending_ = false;
    Vec<D> excess;
    for (int a = 0; a < D; ++a) excess[a] = stress(a, a) - target_;
    ode_.advance(t + h, excess.data());
    const Vec<D> before = length_;
    for (int a = 0; a < D; ++a) length_[a] = ode_.length(a), rate_[a] = ode_.state_rate(a);
    return length_.cwiseQuotient(before);
  }

  void save(ByteWriter& w) const {
    reset_pending_ = true;   // see the header comment
    w.put(length_), w.put(rate_), w.put(target_);
  }
  void load(ByteReader& r) {
    length_ = r.get<Vec<D>>(), rate_ = r.get<Vec<D>>(), target_ = r.get<double>();
    reset_pending_ = true;
  }

 private:
  CellLengthOde ode_;
  Vec<D> length_, rate_;   // rate_: CVODE's rate variable, what a restart starts from
  double target_;
  mutable bool reset_pending_ = false;
  bool restart_every_step_ = false;
};

}  // namespace grains
