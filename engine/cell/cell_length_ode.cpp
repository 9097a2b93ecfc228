#include "cell/cell_length_ode.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include <cvode/cvode.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

namespace grains {

struct CellLengthOde::Cvode {
  SUNContext context = nullptr;
  N_Vector y = nullptr, abstol = nullptr;
  void* memory = nullptr;
  SUNNonlinearSolver solver = nullptr;
  ~Cvode() {
    if (memory) CVodeFree(&memory);
    if (solver) SUNNonlinSolFree(solver);
    if (y) N_VDestroy(y);
    if (abstol) N_VDestroy(abstol);
    if (context) SUNContext_Free(&context);
  }
};

namespace {
void check(int flag, const char* what) {
  if (flag < 0) throw std::runtime_error(fmt::format("barostat: CVODE {} failed (flag {})", what, flag));
}
}  // namespace

CellLengthOde::CellLengthOde(const CellLengthParameters& p) : p_(p), cv_(std::make_unique<Cvode>()) {
  if (p.axes < 1 || p.axes > 3) throw std::invalid_argument("barostat: 1 to 3 cell axes");
  const int n = 2 * p.axes;   // y = (L_1..L_n, dL_1/dt..dL_n/dt)
  check(SUNContext_Create(nullptr, &cv_->context), "context");
  cv_->y = N_VNew_Serial(n, cv_->context);
  cv_->abstol = N_VNew_Serial(n, cv_->context);
  double* tol = N_VGetArrayPointer(cv_->abstol);
  for (int a = 0; a < p.axes; ++a) tol[a] = p.atol_length, tol[p.axes + a] = p.atol_length / p.time_unit;
  for (int a = 0; a < n; ++a) N_VGetArrayPointer(cv_->y)[a] = 1.0;
  // Non-stiff (the cell period spans many particle steps): Adams with fixed-point iteration, no Jacobian.
  cv_->memory = CVodeCreate(CV_ADAMS, cv_->context);
  if (!cv_->memory) throw std::runtime_error("barostat: CVodeCreate failed");
  check(CVodeInit(cv_->memory, [](double t, N_Vector y, N_Vector yd, void* self) { return rhs(t, y, yd, self); }, 0.0,
                  cv_->y),
        "init");
  check(CVodeSetUserData(cv_->memory, this), "user data");
  check(CVodeSVtolerances(cv_->memory, p.rtol, cv_->abstol), "tolerances");
  cv_->solver = SUNNonlinSol_FixedPoint(cv_->y, 0, cv_->context);
  check(CVodeSetNonlinearSolver(cv_->memory, cv_->solver), "nonlinear solver");
  check(CVodeSetMaxNumSteps(cv_->memory, 100000), "max steps");
  // CVODE's own messages would go to stderr (an FMU's host's, too); a failure is reported by advance().
  check(CVodeSetErrHandlerFn(cv_->memory, [](int, const char*, const char*, char*, void*) {}, nullptr), "error handler");
}

CellLengthOde::~CellLengthOde() = default;

void CellLengthOde::set_time_unit(double time_unit) {
  p_.time_unit = time_unit;
  double* tol = N_VGetArrayPointer(cv_->abstol);
  for (int a = 0; a < p_.axes; ++a) tol[p_.axes + a] = p_.atol_length / time_unit;
  check(CVodeSVtolerances(cv_->memory, p_.rtol, cv_->abstol), "tolerances");   // CVODE keeps its own copy
}

int CellLengthOde::rhs(double, void* yv, void* ydv, void* self_) {
  const auto* self = static_cast<const CellLengthOde*>(self_);
  const auto& p = self->p_;
  const double* y = N_VGetArrayPointer(static_cast<N_Vector>(yv));
  double* yd = N_VGetArrayPointer(static_cast<N_Vector>(ydv));
  const int n = p.axes;
  for (int a = 0; a < n; ++a) {
    double area = 1;   // V / L_a: the product of the other lengths
    for (int b = 0; b < n; ++b)
      if (b != a) area *= y[b];
    const double L = y[a], rate = y[n + a];
    double accel = (area * self->excess_[a] - (p.damping + self->extra_damping_[a]) * rate) / p.mass;
    // Strain-rate cap: the length moves at most at cap * L. At the cap the rate variable follows the
    // limit as L moves, d(+-cap L)/dt = cap * (cap L) for either sign, unless the forcing takes it back
    // inside: rate = +-cap L is then an invariant that CVODE's linear multistep keeps to round-off (the
    // 1e-12 band keeps round-off from flipping the branch). A rate held fixed at the cap would wind up while
    // compressing (L shrinks under it), so the cell would go on shrinking once the stress turned, and expanding
    // the limit would outgrow it and flip the branch at every step.
    const double limit = p.rate_cap * L;
    if (std::abs(rate) >= limit * (1 - 1e-12)) {
      const double follow = p.rate_cap * limit;
      accel = rate > 0 ? std::min(accel, follow) : std::max(accel, follow);
    }
    yd[a] = std::clamp(rate, -limit, limit);
    yd[n + a] = accel;
  }
  return 0;
}

void CellLengthOde::reset(const double* length, const double* rate, double t) {
  double* y = N_VGetArrayPointer(cv_->y);
  for (int a = 0; a < p_.axes; ++a) y[a] = length[a], y[p_.axes + a] = rate[a];
  t_ = t;
  const auto so_far = statistics();
  steps_before_ = so_far.internal_steps, rhs_before_ = so_far.rhs_evaluations;
  check(CVodeReInit(cv_->memory, t, cv_->y), "re-initialisation");
  ++reinitialisations_;
}

void CellLengthOde::advance(double t_end, const double* stress_excess) {
  for (int a = 0; a < p_.axes; ++a) excess_[a] = stress_excess[a];
  if (!(t_end > t_)) return;
  // The forcing changes after t_end: CVODE must not step past it.
  check(CVodeSetStopTime(cv_->memory, t_end), "stop time");
  double reached = t_;
  const int flag = CVode(cv_->memory, t_end, cv_->y, &reached, CV_NORMAL);
  if (flag < 0) {   // formatted only on failure: this runs every step
    char* name = CVodeGetReturnFlagName(flag);   // malloc'ed by CVODE
    const std::string reason = name ? name : "unknown";
    std::free(name);
    // Name the likeliest cause from the terms of the equation, and quote the damping with the contacts' share: a
    // fixed list of suspects (the mass, the pressure, the contacts) misleads where the damping is the cause.
    const double h = t_end - t_, extra = *std::max_element(extra_damping_.begin(), extra_damping_.begin() + p_.axes);
    const double damping_steps = (p_.damping + extra) / p_.mass * h;   // the damping's rate times the step
    const bool finite_excess = std::all_of(excess_.begin(), excess_.begin() + p_.axes, [](double x) { return std::isfinite(x); });
    const std::string cause =
        !finite_excess ? "the stress excess is not finite: the pressure's scale overflowed (look at cell.pressure, "
                         "cell.force_unit or adhesion.force, the unit of P*)"
        : damping_steps > 5e4   // CVODE takes about 1.3 steps per relaxation, at most 100000 a call
            ? fmt::format("the damping makes the equation stiff: (eta_c + eta_contacts) / M_c times the step is {:.3g}, and "
                          "CVODE's non-stiff method needs about that many steps per particle step (at most 100000); lower "
                          "{} or raise cell.mass", damping_steps,
                          extra > p_.damping ? "cell.contact_damping" : "cell.damping_ratio")
            : "the cell's equation is non-finite or too stiff for the step; look at cell.mass, cell.pressure (and its "
              "unit, cell.force_unit), the contacts' stiffness and time.dt";
    throw std::runtime_error(fmt::format(
        "barostat: CVODE integration to t = {} (a step of {:.6g}) failed ({}, flag {}) with stress excess ({}) on a cell "
        "of mass cell.mass = {:.6g}, damping eta_c = {:.6g} (cell.damping_ratio) and eta_contacts = {:.6g} at most "
        "(cell.contact_damping): {}", t_end, h, reason, flag, fmt::join(excess_.begin(), excess_.begin() + p_.axes, ", "),
        p_.mass, p_.damping, extra, cause));
  }
  t_ = t_end;
}

double CellLengthOde::length(int a) const { return N_VGetArrayPointer(cv_->y)[a]; }
double CellLengthOde::state_rate(int a) const { return N_VGetArrayPointer(cv_->y)[p_.axes + a]; }
double CellLengthOde::rate(int a) const {
  const double limit = p_.rate_cap * length(a);
  return std::clamp(state_rate(a), -limit, limit);
}

CellLengthStatistics CellLengthOde::statistics() const {
  long steps = 0, rhs_evals = 0;
  CVodeGetNumSteps(cv_->memory, &steps);
  CVodeGetNumRhsEvals(cv_->memory, &rhs_evals);
  return {steps_before_ + steps, rhs_before_ + rhs_evals, reinitialisations_};
}

void CellLengthOde::set_statistics(const CellLengthStatistics& totals) {
  const auto now = statistics();
  steps_before_ += totals.internal_steps - now.internal_steps;
  rhs_before_ += totals.rhs_evaluations - now.rhs_evaluations;
  reinitialisations_ = totals.reinitialisations;
}

}  // namespace grains
