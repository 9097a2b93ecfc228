// A simulation's complete state as bytes (save_state / restore_state), for checkpoints and FMU hosts.
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "core/byte_stream.hpp"
#include "core/simulation_impl.hpp"

namespace grains {

// First word of a saved state: "GRN" and a version, raised whenever the layout changes (version 2: the
// 2D tangential spring became one number per pair; 3: no previous angular accelerations, which only an
// unused spin prediction read; 4: the drag.rate control; 5: no angular accelerations, which the torques
// give; 6: the previous force instead of both accelerations; 7: the shell of pairs near contact; a scene with
// a pressure ramp, new since, appends the ramp's on flag, and one with cell.contact_damping > 0 then the cell's
// contact damping; 8: a check sum ends the state, the clock's origin and whole steps follow the step count; 9: the
// adhesive contacts' parting charges of the last evaluation; 10: a gravity scene's energy check follows its
// aggregation time; 11: the barostat's last stress, which its next step extrapolates from; 12: the particles' periodic
// images, after their orientations; 13: whether the clamp warning was given, after the barostat's stress; 14: whether a
// gravity scene's pass-through warning was given, after the energy check's record; 15: whether its softened-core
// warning was given, after that; 16: whether its orbit-step warning was given, at the start-up or a host's gravity.G,
// after that; 17: the barostat's time unit, after its last stress).
// States of builds before the word start with D (2, 3).
constexpr std::uint32_t state_format = 0x47524e11;

// GCC 12 inlines the writer's first insert into its empty vector here and wrongly flags it as overflowing
// (-Wstringop-overflow).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wstringop-overflow"
template <int D>
std::vector<std::byte> SimulationImpl<D>::save_state() const {
  ByteWriter w;
  const auto& P = sys_.particles;
  w.put(state_format), w.put<int>(D), w.put<std::uint64_t>(P.size());
  w.put(sys_.time), w.put(sys_.step), w.put(clock_origin_), w.put(clock_steps_);
  w.put_vector(P.position), w.put_vector(P.velocity), w.put_vector(P.force), w.put_vector(P.force_prev),
      w.put_vector(P.angular_velocity), w.put_vector(P.torque), w.put_vector(P.orientation);
  w.put_vector(P.image);
  sys_.neighbours.save(w);
  sys_.shell.save(w);
  for (const auto& m : modules_) m->save(w);
  if (analysis_) {
    w.put(aggregation_time_);
    const EnergyWatch& e = energy_watch_;   // field by field: no padding bytes in the state
    w.put(e.first), w.put(e.minimum), w.put(e.minimum_time), w.put(e.started), w.put(e.warned);
    w.put(std::uint8_t(pass_through_warned_));
    w.put(std::uint8_t(core_warned_));
    w.put(std::uint8_t(orbit_rule_warned_));
  }
  if (network_) w.put_vector(reference_contacts_), w.put(network_mark_);
  // Whether the clamp warning was given: before the controls, whose restored cell.pressure would give it again.
  if (barostat_) barostat_->save(w), w.put(contact_stress_), w.put(std::uint8_t(pressure_clamp_warned_));
  if (collisions_) collisions_->save(w);
  for (const auto& [index, c] : controls_) w.put(c.get());
  if (has_ramp_) w.put(ramp_.on);   // after the controls: restoring cell.pressure ends the ramp, this resumes it
  // The contacts' damping of the cell, updated every contact_damping_every_ steps: a state saved between two
  // updates continues with the last one (a new simulation would have none until the next).
  if (barostat_ && contact_damping_ > 0) w.put(barostat_->contact_damping());
  const std::uint64_t sum = check_sum(w.written());   // last: over everything before it
  w.put(sum);
  return w.take();
}
#pragma GCC diagnostic pop

// What a loaded state's indices address must exist: the lists' rows are the particles, the shell's entries
// the list's, the modules' per-pair arrays the list's pairs.
template <int D>
void SimulationImpl<D>::check_loaded() const {
  const auto& P = sys_.particles;
  const std::size_t N = P.size();
  // Every per-particle array has a row per particle: a state of other lengths was read past its end at the next step.
  for (std::size_t n : {P.position.size(), P.velocity.size(), P.force.size(), P.force_prev.size(), P.angular_velocity.size(),
                        P.torque.size(), P.orientation.size(), P.image.size()})
    if (n != N) throw SimulationError(fmt::format("the saved particle arrays have {} rows, the scene {} particles", n, N));
  // A position a run keeps lies near its cell on a periodic axis: one 1e19 cells off overflowed the image count that
  // wrapping it adds up (found by fuzzing); a non-finite one is no position anywhere.
  const auto& box = sys_.box;
  for (std::size_t i = 0; i < N; ++i)
    for (int a = 0; a < D; ++a) {
      const double x = P.position[i][a];
      if (!std::isfinite(x) || box.cells_off(P.position[i], a) > Box<D>::max_cells_off)
        throw SimulationError(fmt::format("the saved position of particle {} is {} on axis {}: a finite number, within "
                                          "1e6 cell lengths of the periodic cell", i, x, a));
    }
  const auto& list = sys_.neighbours;
  const auto& shell = sys_.shell;
  if (!list.start.empty() && list.start.size() != N + 1)
    throw SimulationError("the saved neighbour list has another particle count");
  if (!shell.start.empty() && shell.start.size() != N + 1)
    throw SimulationError("the saved shell list has another particle count");
  for (std::size_t e = 0; e < shell.entry.size(); ++e)
    if (shell.entry[e] >= list.pair_count() || list.partner[shell.entry[e]] != shell.partner[e] ||
        list.owner[shell.entry[e]] != shell.owner[e])
      throw SimulationError("the saved shell list does not fit the saved neighbour list");
  for (const auto& m : modules_) m->check_loaded(sys_);
  if (collisions_) collisions_->check_loaded(list);
}

// A state that does not fit leaves the simulation as it was.
template <int D>
void SimulationImpl<D>::restore_state(std::span<const std::byte> bytes) {
  const auto backup = save_state();
  try {
    load_state(bytes);
  } catch (const std::exception& e) {
    load_state(backup);
    throw SimulationError(fmt::format("restore_state: {}; the simulation is unchanged", e.what()));
  }
}

template <int D>
void SimulationImpl<D>::load_state(std::span<const std::byte> all) {
  // The format word first (another build's state is named as such), then the check sum over the rest.
  if (all.size() >= sizeof(std::uint32_t)) {
    std::uint32_t format;
    std::memcpy(&format, all.data(), sizeof format);
    if (format != state_format)
      throw SimulationError(fmt::format("the saved state has format {:#x}, this build reads {:#x} (saved by another "
                                        "version of grains)", format, state_format));
  }
  constexpr std::size_t sum_size = sizeof(std::uint64_t);
  if (all.size() < sizeof(std::uint32_t) + sum_size) throw SimulationError("the saved state is empty or truncated");
  const std::span<const std::byte> bytes = all.first(all.size() - sum_size);
  std::uint64_t sum;
  std::memcpy(&sum, all.data() + bytes.size(), sum_size);
  if (sum != check_sum(bytes))
    throw SimulationError("the saved state is corrupted or truncated (its check sum does not match its bytes)");
  ByteReader r(bytes);
  auto& P = sys_.particles;
  r.get<std::uint32_t>();   // the format word, checked above
  if (sys_.pending_kick.active) clear_pending_kick();   // a state has none (a failed step may have left one)
  if (r.get<int>() != D || r.get<std::uint64_t>() != P.size())
    throw SimulationError("the saved state belongs to a scene of another dimension or particle count");
  sys_.time = r.get<double>(), sys_.step = r.get<long>(), clock_origin_ = r.get<double>(), clock_steps_ = r.get<long>();
  r.get_vector(P.position), r.get_vector(P.velocity), r.get_vector(P.force), r.get_vector(P.force_prev),
      r.get_vector(P.angular_velocity), r.get_vector(P.torque), r.get_vector(P.orientation);
  r.get_vector(P.image);
  sys_.neighbours.load(r);
  sys_.shell.load(r);
  for (auto& m : modules_) m->load(r);
  if (analysis_) {
    aggregation_time_ = r.get<double>();
    EnergyWatch& e = energy_watch_;
    e.first = r.get<double>(), e.minimum = r.get<double>(), e.minimum_time = r.get<double>();
    e.started = r.get<std::uint8_t>(), e.warned = r.get<std::uint8_t>();
    pass_through_warned_ = r.get<std::uint8_t>() != 0;
    core_warned_ = r.get<std::uint8_t>() != 0;
    orbit_rule_warned_ = r.get<std::uint8_t>() != 0;
  }
  if (network_) r.get_vector(reference_contacts_), network_mark_ = r.get<double>();
  if (barostat_) {
    barostat_->load(r);
    contact_stress_ = r.get<Tensor<D>>();
    for (int a = 0; a < D; ++a)   // the next step's forcing of the cell
      for (int b = 0; b < D; ++b)
        if (!std::isfinite(contact_stress_(a, b)))
          throw SimulationError(fmt::format("the saved contact stress is {} at ({}, {}): a finite number", contact_stress_(a, b), a, b));
    pressure_clamp_warned_ = r.get<std::uint8_t>() != 0;
    sys_.box.length = barostat_->length();
  }
  if (collisions_) collisions_->load(r);
  loading_controls_ = true;
  try {
    for (auto& [index, c] : controls_) c.set(r.get<double>());   // the network mark is unchanged: no new reference
  } catch (...) {
    loading_controls_ = false;
    throw;
  }
  loading_controls_ = false;
  if (has_ramp_) ramp_.on = r.get<bool>();
  if (barostat_ && contact_damping_ > 0) {
    const Vec<D> eta = r.get<Vec<D>>();
    for (int a = 0; a < D; ++a)
      if (!(std::isfinite(eta[a]) && eta[a] >= 0))
        throw SimulationError(fmt::format("the saved contact damping of the cell is {} on axis {}: a finite number >= 0", eta[a], a));
    barostat_->set_contact_damping(eta);
  }
  if (!r.done()) throw SimulationError("the saved state has trailing bytes (another scene?)");
  check_loaded();
  for (auto& stamp : refreshed_) stamp = {};
}

// This file's members, instantiated one by one: each of the Simulation's files instantiates its own
// (a whole-class instantiation may appear in only one file of a program).
#define GRAINS_SIMULATION_STATE_MEMBERS(D) \
  template std::vector<std::byte> SimulationImpl<D>::save_state() const; \
  template void SimulationImpl<D>::check_loaded() const; \
  template void SimulationImpl<D>::restore_state(std::span<const std::byte>); \
  template void SimulationImpl<D>::load_state(std::span<const std::byte>);
GRAINS_SIMULATION_STATE_MEMBERS(2)
GRAINS_SIMULATION_STATE_MEMBERS(3)
#undef GRAINS_SIMULATION_STATE_MEMBERS

}  // namespace grains
