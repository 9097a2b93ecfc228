// The step: the runs of steps a host asks for, and each step's passes (kick, drift and predict; the cell's
// move; the lists' refresh; the forces; the kick left pending for the next step). The whole hot path is in
// this one file, so that the compiler inlines it as one piece.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <omp.h>

#include "cell/affine_contact_damping.hpp"
#include "core/simulation_impl.hpp"
#include "core/thread_share.hpp"

namespace grains {

template <int D>
void SimulationImpl<D>::step(double duration) {
  if (!(duration >= 0) || !std::isfinite(duration))
    throw SimulationError(fmt::format("step: duration {} is not allowed: a finite value >= 0", duration));
  if (duration / dt_ > max_steps)   // beyond it the step count overflows
    throw SimulationError(fmt::format("step: duration {} is {:.3g} steps of dt = {:.6g}; at most 1e15 steps at a time",
                                      duration, duration / dt_, dt_));
  const double target = sys_.time + duration;
  const long whole = long(std::floor(duration / dt_ * (1 + 1e-12)));
  // The remainder is judged on the duration itself, not on the accumulated time (whose rounding
  // grows with t): a duration that is a whole number of dt takes exactly those steps, the same as
  // step_n, and keeps the same time values; otherwise one shorter step lands on t + duration.
  const bool remainder = duration - double(whole) * dt_ > 1e-9 * dt_;
  run_steps([&] {
    for (long k = 0; k < whole; ++k) one_step(dt_, !remainder && k == whole - 1);
    if (remainder) one_step(target - sys_.time, true, target);
  });
}

template <int D>
void SimulationImpl<D>::step_n(long n) {
  run_steps([&] {
    for (long k = 0; k < n; ++k) one_step(dt_, k == n - 1);
  });
}

template <int D>
void SimulationImpl<D>::step_evenly(double duration, long n) {
  if (!(duration > 0) || !std::isfinite(duration) || n < 1 || duration / double(n) > dt_ * (1 + 1e-12))
    throw SimulationError(fmt::format("step_evenly: {} equal steps of {} are not allowed: finite, positive, at most dt = {}",
                                      n, duration / double(n), dt_));
  const double target = sys_.time + duration, h = duration / double(n);
  run_steps([&] {
    for (long k = 0; k < n - 1; ++k) one_step(h, false);
    one_step(target - sys_.time, true, target);
  });
}

// Runs steps with each step's second half kick deferred to the next one's first pass where nothing
// reads the velocities between steps; the last kick is done before returning (also on an error).
template <int D>
template <class Steps>
void SimulationImpl<D>::run_steps(Steps steps) {
  try {
    steps();
  } catch (...) {
    try { settle(); } catch (...) {}   // the first error is the one to report
    throw;
  }
  settle();
  // Sums that overflow while every grain is finite, refused where the run makes them, not only where outputs are read
  // (a host reading positions alone would not see them): at every call that has taken 64 steps since the last check,
  // an O(N) pass amortised over them (each call, it made a host stepping one dt at a time 1.7 times slower).
  if (sys_.step - kinetic_sums_checked_ >= 64 || sys_.step < kinetic_sums_checked_)
    check_kinetic_sums(), kinetic_sums_checked_ = sys_.step;
}

// Nothing is pending between runs: a run's last kick is done before it returns.
template <int D>
void SimulationImpl<D>::settle() {
  if (!std::isfinite(do_pending_kick())) check_finite_at_step(sys_.step);
}

// The time after a step of h: a whole step's is the clock's origin plus the whole steps since, times dt
// (one rounding, however long the run: a sum of dt drifted from a host's own clock by ~1e-16 t per step);
// a shorter step's (a host's remainder) is the clock's new origin.
template <int D>
double SimulationImpl<D>::time_after(double h) const {
  return h == dt_ ? clock_origin_ + double(clock_steps_ + 1) * dt_ : sys_.time + h;
}

// `last`: the run's last step, after which a host, an observer or a moving cell may read the stress.
// `end`: where the step lands (a remainder step's target), else time_after(h).
template <int D>
void SimulationImpl<D>::one_step(double h, bool last, double end) {
  const double t_end = std::isnan(end) ? time_after(h) : end;
  Vec<D> scale = Vec<D>::Ones();
  const bool cell_moves = barostat_ && cell_active_;
  // The contact virial is summed where the stress will be read: for the barostat at every step while
  // the cell moves, else after the run's last step (a held cell, as in a type-2 aggregation, saves it).
  sys_.want_virial = barostat_ && (cell_moves || last);
  if (barostat_ && ramp_.on) follow_ramp();
  if (cell_moves) {   // the cell moves under the stress of the last force evaluation (operator splitting)
    if (contact_damping_ > 0 && sys_.step % contact_damping_every_ == 0) {
      barostat_->set_contact_damping(contact_damping_ * affine_contact_damping<D>(sys_, cn_));
      warn_stiff_cell_damping();
    }
    const Tensor<D> sigma = stress_between_steps();   // outside the clock: cvode_seconds is the integrator's own time
    const auto start = std::chrono::steady_clock::now();
    scale = barostat_->advance(sys_.time, t_end, sigma);
    cvode_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    resize_cell(scale);
  }
  for (auto& m : modules_) m->begin_step(sys_, h);
  double moved = 0;
  double witness = first_half(h, cell_moves, scale, moved);
  sys_.affine_flow = cell_moves;
  if (cell_moves) {
    sys_.cell_scale = scale;
    sys_.strain_rate = barostat_->rate().cwiseQuotient(sys_.box.length);
  }
  refresh_lists(moved);
  sys_.dt = h;
  compute_forces(true);
  const double keep = drag_ > 0 ? std::exp(-drag_ * h) : 1.0;
  // The kick waits for the next step's first pass, unless the collision log reads the velocities after
  // each step (the barostat reads the kinetic stress of the kick to come: stress_between_steps).
  defer_kick(h, keep);
  if (collisions_) witness += do_pending_kick();
  for (auto& m : modules_) m->finish_step(sys_);
  if (sys_.want_virial) contact_stress_ = contact_stress<D>(sys_.virial, sys_.box.volume());
  sys_.time = t_end;
  if (h == dt_ && std::isnan(end)) ++clock_steps_;
  else clock_origin_ = t_end, clock_steps_ = 0;
  ++sys_.step;
  if (!std::isfinite(witness)) check_finite_at_step(sys_.step);
  if (analysis_ && sys_.step % analysis_every_ == 0) track_aggregation();
  if (collisions_) collisions_->after_step(sys_, h);
}

// Kick, drift and predict; follow the cell; measure how far the particles moved since the list was
// built; clear the forces: all per particle, so one pass does them, each thread its own share
// (core/thread_share.hpp), in one parallel region. On a few thousand particles a step takes some tens
// of microseconds, and every region that opens and joins costs a few of them. Returns the integrator's
// witness.
template <int D>
double SimulationImpl<D>::first_half(double h, bool cell_moves, const Vec<D>& scale, double& moved) {
  auto& P = sys_.particles;
  auto& pending = sys_.pending_kick;
  const std::size_t N = P.size();
  double witness = 0, largest = 0, kicked = 0;
  integrator_detail::DriftGeometry geometry;
  if (cell_moves) {
    geometry.follow = true;
    for (int a = 0; a < D; ++a) geometry.lower[a] = sys_.box.lower[a], geometry.scale[a] = scale[a];
  }
  // The reference positions to measure the moves against, the shell's if built (refresh_lists); none:
  // a new particle count, a new list.
  const auto reference = !uses_list_          ? typename NeighbourList<D>::Reference{}
                         : sys_.shell.built() ? sys_.shell.reference(N)
                                              : sys_.neighbours.reference(N);
  if (reference.position) measure_from(reference, geometry);
  // A pending kick is done in the same pass, except on the particles kicked early (in runs between them).
  const PendingKick* kick = pending.active ? &pending : nullptr;
  std::sort(pending.early.begin(), pending.early.end());
#pragma omp parallel num_threads(sys_.threads) reduction(+ : witness, kicked) reduction(max : largest)
  {
    const auto [b, e] = thread_share(N, omp_get_thread_num(), omp_get_num_threads());
    const auto pass = [&](std::size_t from, std::size_t to, const PendingKick* with) {
      const auto sums = !rotate_ ? kick_drift_predict<D, false>(P, h, from, to, geometry, with)
                        : orient_ ? kick_drift_predict<D, true>(P, h, from, to, geometry, with)
                                  : kick_drift_predict<D, true, false>(P, h, from, to, geometry, with);
      witness += sums.witness, kicked += sums.kick_witness;
      largest = std::max(largest, sums.largest_move);
    };
    each_run_between(pending.early, b, e, [&](std::size_t from, std::size_t to) { pass(from, to, kick); },
                     [&](std::size_t p) { pass(p, p + 1, nullptr); });
  }
  // kick_drift_predict cleared the previous forces and the torques: the coming evaluation adds into them.
  P.force.swap(P.force_prev);
  moved = uses_list_ && !reference.position ? std::numeric_limits<double>::infinity() : largest;
  if (pending.active) {   // the kick belonged to the step before this one
    const double kick_witness = kicked + pending.early_witness;
    clear_pending_kick();
    if (!std::isfinite(kick_witness)) check_finite_at_step(sys_.step);
  }
  return witness;
}

// Calls run(from, to) on the runs of [b, e) between the sorted particles `skip`, and single(p) on each of those.
template <int D>
template <class Run, class Single>
void SimulationImpl<D>::each_run_between(const std::vector<std::uint32_t>& skip, std::size_t b, std::size_t e, Run run, Single single) {
  std::size_t from = b;
  for (auto it = std::lower_bound(skip.begin(), skip.end(), std::uint32_t(b)); it != skip.end() && *it < e; ++it) {
    if (*it > from) run(from, std::size_t(*it));
    single(std::size_t(*it));
    from = std::size_t(*it) + 1;
  }
  if (from < e) run(from, e);
}

// The moves are measured from `reference` (a list's or the shell's), as the cell has carried it.
template <int D>
void SimulationImpl<D>::measure_from(const typename NeighbourList<D>::Reference& reference, integrator_detail::DriftGeometry& g) {
  g.reference = reinterpret_cast<const double*>(reference.position);
  g.carried = reference.strain != Vec<D>::Ones();
  for (int a = 0; a < D; ++a) g.reference_lower[a] = reference.lower[a], g.strain[a] = reference.strain[a];
}

// After a step's first pass: rebuilds the list where it is stale, else the shell where it is (or
// where it is not built yet). `moved` is the largest squared move the pass measured: from the shell's
// reference positions if the shell is built, else from the list's. The list is rebuilt exactly when
// it would be without a shell: by its own measure, taken where the shell's bound cannot rule it out.
template <int D>
void SimulationImpl<D>::refresh_lists(double moved) {
  if (!uses_list_) return;
  auto& shell = sys_.shell;
  if (!shell.built()) {
    if (sys_.neighbours.stale_after(moved)) rebuild();
    else if (shell.enabled())
      shell.build(sys_.neighbours, sys_.particles.position, sys_.particles.radius, std::sqrt(moved), sys_.step, false);
    return;
  }
  double list_move = -1;   // not measured
  if (sys_.neighbours.stale_after(shell.list_move_bound(moved))) {
    list_move = list_largest_move();
    if (sys_.neighbours.stale_after(list_move)) return rebuild();
  }
  if (shell.stale_after(moved))
    shell.build(sys_.neighbours, sys_.particles.position, sys_.particles.radius,
                std::sqrt(list_move >= 0 ? list_move : list_largest_move()), sys_.step, true);
}

template <int D>
void SimulationImpl<D>::rebuild() {
  if (!uses_list_) return;
  auto& P = sys_.particles;
  for (const auto& x : P.position)   // never grid a non-finite position
    if (!x.allFinite()) check_finite_at_step(sys_.step + 1);
  check_within_reach_of_cell();
  for (std::size_t i = 0; i < P.size(); ++i) P.position[i] = sys_.box.wrap(P.position[i], &P.image[i]);
  sys_.neighbours.build(P.position, P.radius, sys_.box, sys_.threads);
  if (sys_.shell.enabled()) sys_.shell.build(sys_.neighbours, P.position, P.radius, 0.0, sys_.step, false);
  for (auto& m : modules_) m->after_rebuild(sys_.neighbours);
  if (collisions_) collisions_->after_rebuild(sys_.neighbours);
}

// The largest squared move from the list's reference positions, as the first pass would have
// measured it against them (infinite for a list of another particle count).
template <int D>
double SimulationImpl<D>::list_largest_move() const {
  const auto& P = sys_.particles;
  const auto reference = sys_.neighbours.reference(P.size());
  if (!reference.position) return std::numeric_limits<double>::infinity();
  integrator_detail::DriftGeometry g;
  measure_from(reference, g);
  const double* x = reinterpret_cast<const double*>(P.position.data());
  return D == 2 ? integrator_detail::largest_move_2(P.size(), x, g) : integrator_detail::largest_move_3(P.size(), x, g);
}

// Leaves a step's second half kick pending for the next step's first pass (core/pending_kick.hpp).
template <int D>
void SimulationImpl<D>::defer_kick(double h, double keep) {
  auto& pending = sys_.pending_kick;
  pending.kicked.resize(sys_.particles.size(), 0);
  pending.active = true, pending.h = h, pending.keep = keep, pending.spins = rotate_;
}

// Does the pending kick (on every particle not kicked early, each thread its share); returns the sum of
// the kicked velocities and spins (finite exactly when every one is).
template <int D>
double SimulationImpl<D>::do_pending_kick() {
  auto& pending = sys_.pending_kick;
  if (!pending.active) return 0;
  auto& P = sys_.particles;
  std::sort(pending.early.begin(), pending.early.end());
  double witness = 0;
#pragma omp parallel num_threads(sys_.threads) reduction(+ : witness)
  {
    const auto [b, e] = thread_share(P.size(), omp_get_thread_num(), omp_get_num_threads());
    each_run_between(pending.early, b, e, [&](std::size_t from, std::size_t to) {
        witness += rotate_ ? kick_range<D, true>(P, pending.h, pending.keep, from, to)
                           : kick_range<D, false>(P, pending.h, pending.keep, from, to);
      }, [](std::size_t) {});
  }
  witness += pending.early_witness;
  clear_pending_kick();
  return witness;
}

// The ramp's target for the step about to be taken (frozen over it, like the stress).
template <int D>
void SimulationImpl<D>::follow_ramp() {
  target_reduced_ = ramp_.at(sys_.time);
  if (ramp_.ended(sys_.time)) ramp_.on = false;
  barostat_->follow_target_pressure(target_reduced_ * pressure_scale_, rate_cap(target_reduced_));
}

// The cell takes its new lengths: the list's image shifts follow, and a cell too small for its
// particles stops the run. The particles follow in the step's first pass (DriftGeometry::follow).
template <int D>
void SimulationImpl<D>::resize_cell(const Vec<D>& scale) {
  sys_.box.length = barostat_->length();
  sys_.neighbours.follow_cell(scale, sys_.box);
  sys_.shell.follow_cell(scale, sys_.box);
  for (int a = 0; a < D; ++a)
    if (!(sys_.box.length[a] > 2 * cell_list_reach_)) {
      // a cell collapsing under a pressure its clamped contacts cannot carry is another cause, with another cure
      const long clamped = clamped_now();
      throw SimulationError(fmt::format(
          "step {}: the cell has shrunk to {:.6g} on axis {}, no longer than twice the interaction reach "
          "(2 R_max + skin = {:.6g}): too few particles for a periodic cell at this density; use more particles{}",
          sys_.step + 1, sys_.box.length[a], a, cell_list_reach_,
          // the light cell first: known from the start, it also crushes contacts past the clamp as it collapses
          cell_too_light_ ? std::string(" (or, as warned at the start, a heavier cell.mass: a cell too light for the "
                                        "step breathes ever wider until it collapses)")
          : clamped > 0 ? fmt::format(" (or, since {} contacts are clamped now, overlapping past contact.overlap_limit, "
                                      "a lower pressure: the contacts cannot carry this one)", clamped)
                        : std::string()));
    }
}

// Contacts clamped at the last force evaluation (the contact module's observable; 0 without contacts).
template <int D>
long SimulationImpl<D>::clamped_now() const {
  std::vector<std::pair<std::string, double>> out;
  for (const auto& m : modules_) m->observe(sys_, out);
  for (const auto& [name, value] : out)
    if (name == "clamped_contacts") return long(value);
  return 0;
}

// The stress the barostat reads between the steps of a run: while the last kick is pending, its
// kinetic part is that of the velocities the kick will give (bit for bit: integrator.hpp).
template <int D>
Tensor<D> SimulationImpl<D>::stress_between_steps() {
  auto& pending = sys_.pending_kick;
  if (!pending.active) return stress();
  std::sort(pending.early.begin(), pending.early.end());
  return contact_stress_ + kinetic_sum(&pending) / sys_.box.volume();
}

// sum m u u^T, u the velocity after the pending kick `kick` (its `early` sorted) or, without one, the stored
// velocity. Each thread sums the particles it drifts and kicks (thread_share), whose lines its own cache
// holds, and the sums are added in thread order: deterministic for a thread count, and on one thread the
// particle-order sum of analysis/stress.hpp. (Summed by one thread over every particle, at each step of a
// moving cell, it fetched the other threads' lines and made their next drift fetch them back.)
template <int D>
Tensor<D> SimulationImpl<D>::kinetic_sum(const PendingKick* kick) const {
  const auto& P = sys_.particles;
  const auto add_share = [&](int t, int threads, Tensor<D>& sum) {
    const auto [b, e] = thread_share(P.size(), t, threads);
    if (!kick) return add_kinetic_stress<D>(P, b, e, nullptr, sum);
    each_run_between(kick->early, b, e, [&](std::size_t from, std::size_t to) {
        add_kinetic_stress<D>(P, from, to, kick, sum);
      }, [&](std::size_t p) { add_kinetic_stress<D>(P, p, p + 1, nullptr, sum); });
  };
  const int T = std::max(1, sys_.threads);
  if (T == 1) {
    Tensor<D> sum = Tensor<D>::Zero();
    add_share(0, 1, sum);
    return sum;
  }
  std::vector<Tensor<D>> part(std::size_t(T), Tensor<D>::Zero());
  // T shares whatever number of threads OpenMP starts (a host's parallel region around the step, OMP_THREAD_LIMIT,
  // OMP_DYNAMIC): the sum, and the pressure the barostat follows, depend on T alone.
#pragma omp parallel num_threads(T)
  for (int t = omp_get_thread_num(); t < T; t += omp_get_num_threads()) add_share(t, T, part[std::size_t(t)]);
  Tensor<D> sum = part[0];
  for (std::size_t t = 1; t < part.size(); ++t) sum += part[t];
  return sum;
}

// Records the first time the largest cluster reaches the threshold (called every analysis.every steps).
template <int D>
void SimulationImpl<D>::track_aggregation() {
  if (!analysis_ || !std::isnan(aggregation_time_)) return;
  if (clusters().largest_fraction >= aggregation_threshold_) aggregation_time_ = sys_.time;
}

// Positions are wrapped into the periodic cell at every list build, and no stable step moves a particle far
// between builds: one 1e6 cell lengths off (a finite but huge velocity, e.g. from a restored state: found by
// fuzzing) would overflow the image count that wrapping adds up, so the run stops here and says why.
template <int D>
void SimulationImpl<D>::check_within_reach_of_cell() const {
  const auto& P = sys_.particles;
  const auto& box = sys_.box;
  for (std::size_t i = 0; i < P.size(); ++i)
    for (int a = 0; a < D; ++a) {
      const double cells = box.cells_off(P.position[i], a);
      if (cells > Box<D>::max_cells_off)
        throw SimulationError(fmt::format(
            "particle {} is {:.3g} cell lengths from the periodic cell on axis {} at step {} (t = {:.9g}), moved "
            "there since the neighbour list's last build: its velocity is ({}), which no stable step reaches; {}",
            i, cells, a, sys_.step + 1, sys_.time, fmt::join(P.velocity[i], ", "), blow_up_hint()));
    }
}

template <int D>
void SimulationImpl<D>::check_finite_at_step(long step) const { check_finite(fmt::format("step {} (t = {:.9g})", step, sys_.time)); }

template <int D>
void SimulationImpl<D>::check_finite(const std::string& when) const {
  const auto& P = sys_.particles;
  for (std::size_t i = 0; i < P.size(); ++i) {
    const bool bad = !P.position[i].allFinite() || !P.velocity[i].allFinite() || !P.force[i].allFinite() ||
                     !P.angular_velocity[i].allFinite();
    if (!bad) continue;
    throw SimulationError(fmt::format("non-finite value at {}: particle {} (mass {:.6g}) has position ({}), velocity "
                                      "({}), force ({}); {}",
                                      when, i, P.mass[i], fmt::join(P.position[i], ", "), fmt::join(P.velocity[i], ", "),
                                      fmt::join(P.force[i], ", "), blow_up_hint()));
  }
}

// What a run that blew up should look at. Blame the step rules (or the energy check's finding) only when a check
// found them broken.
template <int D>
std::string SimulationImpl<D>::blow_up_hint() const {
  // A gravitational constant whose closest pair force overflows (gravity.G up to 1e308 is allowed, and a host may set
  // it while stepping): named first, for every other reading of the failure would mislead.
  if (gravity_ && !sys_.particles.mass.empty() && gravity_->softening_length() > 0 && gravity_->G() > 0) {
    const double m = *std::max_element(sys_.particles.mass.begin(), sys_.particles.mass.end());
    const double eps = gravity_->softening_length(), closest = gravity_->G() * m / eps * m / eps;
    if (!std::isfinite(closest) || closest > 1e300)
      return fmt::format("gravity.G = {:.6g}, with masses up to {:.6g} and softening length {:.6g}, makes the closest pair's "
                         "force G m^2 / eps^2 = {:.3g}, past what doubles hold: lower gravity.G (or the masses)",
                         gravity_->G(), m, eps, closest);
  }
  return warnings_.empty()
             ? fmt::format("dt = {:.6g} passed the time-step checks at start-up, so look at the initial (or restored) "
                           "state (coincident or deeply overlapping particles) and the scene's parameters", dt_)
             : fmt::format("the checks warned: {}", fmt::join(warnings_, "; "));
}

// Instantiated member by member, the members other files call (a whole-class instantiation would emit
// every helper for other files to call): the step's helpers are instantiated only where the step calls
// them, and inlined there.
#define GRAINS_SIMULATION_STEP_MEMBERS(D) \
  template void SimulationImpl<D>::step(double); \
  template void SimulationImpl<D>::step_n(long); \
  template void SimulationImpl<D>::step_evenly(double, long); \
  template void SimulationImpl<D>::rebuild(); \
  template Tensor<D> SimulationImpl<D>::kinetic_sum(const PendingKick*) const; \
  template void SimulationImpl<D>::track_aggregation(); \
  template void SimulationImpl<D>::check_finite(const std::string&) const;
GRAINS_SIMULATION_STEP_MEMBERS(2)
GRAINS_SIMULATION_STEP_MEMBERS(3)
#undef GRAINS_SIMULATION_STEP_MEMBERS

}  // namespace grains
