// The cell-length equations of the barostat (physics.md section 9), integrated by SUNDIALS CVODE:
//   M_c d2L_a/dt2 = (V / L_a) (sigma_aa - P_a) - eta_c dL_a/dt,     a = 1..n (n = 1, 2 or 3),
// with the stress excess (sigma_aa - P_a) frozen over each particle step (operator splitting).
// CVODE keeps its history (order, step size, Nordsieck array) across particle steps: the forcing
// changes a little every step and its error control absorbs that. It is re-initialised only after a
// discontinuity (a new target pressure, a restored state): see reset().
// The strain-rate cap |dL_a/dt| / L_a <= rate_cap is part of the right-hand side: dL/dt is the rate
// clamped to the cap, and at the cap the rate follows the moving limit unless the forcing takes it back
// inside, so no re-initialisation is needed and the rate does not wind up.
#pragma once
#include <array>
#include <memory>

namespace grains {

struct CellLengthParameters {
  int axes = 2;               // n
  double mass = 1;            // M_c
  double damping = 0;         // eta_c
  double rate_cap = 1e300;    // epsilon-dot max = I_a / T0
  double rtol = 1e-6;         // CVODE relative tolerance
  double atol_length = 1e-9;  // CVODE absolute tolerance on L (on dL/dt: this over the time unit)
  double time_unit = 1;       // T = sqrt(a m / F1) at the start pressure: scales the absolute tolerance of the rates
};

struct CellLengthStatistics {
  long internal_steps = 0, rhs_evaluations = 0, reinitialisations = 0;
};

class CellLengthOde {
 public:
  explicit CellLengthOde(const CellLengthParameters& p);
  ~CellLengthOde();
  CellLengthOde(const CellLengthOde&) = delete;
  CellLengthOde& operator=(const CellLengthOde&) = delete;

  // Start (or restart) from lengths and rate variables (state_rate) at time t: drops CVODE's history.
  void reset(const double* length, const double* rate, double t);
  // Integrate from the current time to t_end with the stress excess (sigma_aa - P_a) held fixed.
  void advance(double t_end, const double* stress_excess);
  // Extra damping per axis on top of `damping` (the contacts' resistance to the affine strain rate),
  // held like the stress excess until changed.
  void set_extra_damping(const double* extra) {
    for (int a = 0; a < p_.axes; ++a) extra_damping_[a] = extra[a];
  }
  double extra_damping(int a) const { return extra_damping_[a]; }

  // The cap is part of the right-hand side: change it together with a reset().
  void set_rate_cap(double cap) { p_.rate_cap = cap; }
  // The rates' absolute tolerance is atol_length over this (a restored state's: it was the saving run's start
  // pressure's); takes effect at once, so set it before a reset().
  void set_time_unit(double time_unit);
  double length(int a) const;
  double rate(int a) const;         // dL_a/dt, within the cap
  double state_rate(int a) const;   // the integrated rate variable (may exceed the cap by one step's acceleration)
  double time() const { return t_; }
  const CellLengthParameters& parameters() const { return p_; }
  CellLengthStatistics statistics() const;
  // Sets the running totals (a restored state's), whatever CVODE counted since its last restart.
  void set_statistics(const CellLengthStatistics& totals);

 private:
  static int rhs(double t, void* y, void* ydot, void* self);
  CellLengthParameters p_;
  std::array<double, 3> excess_{}, extra_damping_{};
  double t_ = 0;
  long reinitialisations_ = 0;
  long steps_before_ = 0, rhs_before_ = 0;   // CVODE's counters restart at each re-initialisation
  struct Cvode;   // SUNDIALS handles, kept out of this header
  std::unique_ptr<Cvode> cv_;
};

}  // namespace grains
