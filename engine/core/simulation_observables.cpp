// The outputs, computed in groups when read (refresh), and the particle and box views the writers take.
#include <cmath>
#include <limits>
#include <tuple>
#include <utility>

#include <fmt/format.h>

#include "analysis/bonded_clusters.hpp"
#include "analysis/elastic_moduli.hpp"
#include "analysis/fractal_dimension.hpp"
#include "analysis/yielding_contacts.hpp"
#include "core/simulation_impl.hpp"

namespace grains {

template <int D>
ParticleView SimulationImpl<D>::particles() const {
  const auto& P = sys_.particles;
  ParticleView v;
  v.dimension = D;
  v.count = P.size();
  constexpr int S = D == 3 ? 3 : 1;
  const bool periodic = sys_.box.any_periodic();
  for (std::size_t i = 0; i < P.size(); ++i) {
    // The stored position may lie whole cells outside since the last wrap: the view's image counts those too.
    Image<D> image = P.image[i];
    const Vec<D> x = sys_.box.wrap(P.position[i], &image);
    if (periodic) v.image.insert(v.image.end(), image.begin(), image.end());
    for (int a = 0; a < D; ++a) {
      v.position.push_back(x[a]);
      v.velocity.push_back(P.velocity[i][a]);
      v.force.push_back(P.force[i][a]);
    }
    for (int a = 0; a < S; ++a) v.angular_velocity.push_back(P.angular_velocity[i][a]);
    if (!orient_) {   // not tracked: no orientation in the view (nor in the output)
    } else if constexpr (D == 3) {
      const auto& q = P.orientation[i];
      v.orientation.insert(v.orientation.end(), {q.w(), q.x(), q.y(), q.z()});
    } else {
      v.orientation.push_back(P.orientation[i]);
    }
    v.radius.push_back(P.radius[i]);
    v.mass.push_back(P.mass[i]);
  }
  return v;
}

template <int D>
BoxView SimulationImpl<D>::box() const {
  BoxView b;
  b.dimension = D;
  for (int a = 0; a < D; ++a) {
    b.lower.push_back(sys_.box.lower[a]);
    b.length.push_back(sys_.box.length[a]);
    b.periodic.push_back(sys_.box.periodic[a]);
  }
  return b;
}

// Computes the outputs of one group, unless they are already those of this step: a programme's checks
// read a few outputs every hundred steps, and the others (the contact network's analysis, the energies)
// are computed only when asked for.
template <int D>
void SimulationImpl<D>::refresh(OutputGroup group) const {
  Stamp& stamp = refreshed_[std::size_t(group)];
  if (stamp.step == sys_.step && stamp.time == sys_.time) return;
  switch (group) {
    case OutputGroup::general: refresh_general(); break;
    case OutputGroup::cell: refresh_cell_observables(); break;
    case OutputGroup::network: refresh_network(); break;
    case OutputGroup::bonds: refresh_bonds(); break;
    case OutputGroup::moduli: refresh_moduli(); break;
  }
  stamp = {sys_.step, sys_.time};
}

// Every particle's state is finite (the step checks that), yet a sum over them can overflow: a run that gained
// energy without bound (a step too long for its encounters) stops, naming the sum and the particle with the largest
// kinetic energy, rather than write inf into the outputs. Checked at the end of a stepping call once 64 steps have
// passed since the last check (run_steps: a host's step, the runner's stretch between records) and wherever the outputs
// are computed.
template <int D>
void SimulationImpl<D>::refuse_overflowing_sums(const char* sum) const {
  const auto& P = sys_.particles;
  std::size_t top = 0;
  double top_energy = -1;
  for (std::size_t i = 0; i < P.size(); ++i) {
    const double e = 0.5 * P.mass[i] * P.velocity[i].squaredNorm() + 0.5 * P.inertia[i] * P.angular_velocity[i].squaredNorm();
    if (!(e <= top_energy)) top = i, top_energy = e;
  }
  throw SimulationError(fmt::format(
      "the {} overflows a double at step {} (t = {:.9g}); the particle of the largest kinetic energy is {} (mass {:.6g}, "
      "velocity ({}), angular velocity ({}), kinetic energy {:.6g}); {}",
      sum, sys_.step, sys_.time, top, P.mass[top], fmt::join(P.velocity[top], ", "),
      fmt::join(P.angular_velocity[top], ", "), top_energy, blow_up_hint()));
}

// The kinetic energies and momenta, summed; refused where a sum overflows.
template <int D>
typename SimulationImpl<D>::MotionSums SimulationImpl<D>::motion_sums() const {
  const auto& P = sys_.particles;
  MotionSums s;
  for (std::size_t i = 0; i < P.size(); ++i) {
    // About the origin from the positions as written (wrapped into the cell), so that the file's
    // positions reproduce it; the engine's own may sit one cell outside between wraps.
    const Vec<D> x = sys_.box.wrap(P.position[i]);
    s.translational += 0.5 * P.mass[i] * P.velocity[i].squaredNorm();
    s.rotational += 0.5 * P.inertia[i] * P.angular_velocity[i].squaredNorm();
    s.momentum += P.mass[i] * P.velocity[i];
    if constexpr (D == 3) {
      s.angular_momentum += P.mass[i] * x.cross(P.velocity[i]) + P.inertia[i] * P.angular_velocity[i];
    } else {
      s.angular_momentum[2] += P.mass[i] * (x[0] * P.velocity[i][1] - x[1] * P.velocity[i][0]) +
                               P.inertia[i] * P.angular_velocity[i][0];
    }
  }
  if (!std::isfinite(s.translational + s.rotational)) {   // refused, or a square overflowed where the energy did not
    check_kinetic_sums();
    std::tie(s.translational, s.rotational) = kinetic_energies_scaled();
  }
  if (!s.momentum.allFinite()) refuse_overflowing_sums("momentum");
  if (!s.angular_momentum.allFinite()) refuse_overflowing_sums("angular momentum about the origin");
  return s;
}

// The kinetic energy and momentum alone, as cheaply as they come (no wrap, no angular momentum): what the end of a
// stepping call checks (run_steps). A sum that overflows as computed is summed again with each term formed without
// the overflowing square (a grain of 1e-150 kg at 1e154 m/s has a finite energy) before it is refused.
template <int D>
void SimulationImpl<D>::check_kinetic_sums() const {
  const auto& P = sys_.particles;
  double kinetic = 0;
  Vec<D> momentum = Vec<D>::Zero();
  for (std::size_t i = 0; i < P.size(); ++i) {
    kinetic += P.mass[i] * P.velocity[i].squaredNorm() + P.inertia[i] * P.angular_velocity[i].squaredNorm();
    momentum += P.mass[i] * P.velocity[i];
  }
  if (!momentum.allFinite()) refuse_overflowing_sums("momentum");
  if (std::isfinite(kinetic)) return;
  const auto [translational, rotational] = kinetic_energies_scaled();
  if (!std::isfinite(translational + rotational)) refuse_overflowing_sums("kinetic energy");
}

// Sum 1/2 m v^2 and 1/2 I w^2 as |sqrt(m) v|^2 / 2: no square of a speed that overflows where the energy does not.
template <int D>
std::pair<double, double> SimulationImpl<D>::kinetic_energies_scaled() const {
  const auto& P = sys_.particles;
  double translational = 0, rotational = 0;
  for (std::size_t i = 0; i < P.size(); ++i) {
    translational += 0.5 * (std::sqrt(P.mass[i]) * P.velocity[i]).squaredNorm();
    rotational += 0.5 * (std::sqrt(P.inertia[i]) * P.angular_velocity[i]).squaredNorm();
  }
  return {translational, rotational};
}

template <int D>
void SimulationImpl<D>::refresh_general() const {
  const auto& P = sys_.particles;
  auto& o = observable_values_;
  const MotionSums sums = motion_sums();
  const double kt = sums.translational, kr = sums.rotational;
  const Vec<D>& p = sums.momentum;
  const Eigen::Vector3d& L = sums.angular_momentum;
  o["time"] = sys_.time;
  o["step"] = double(sys_.step);
  o["kinetic_energy"] = kt + kr;
  o["translational_energy"] = kt;
  o["rotational_energy"] = kr;
  for (int a = 0; a < D; ++a) o[fmt::format("momentum_{}", "xyz"[a])] = p[a];
  for (int a = (D == 3 ? 0 : 2); a < 3; ++a) o[fmt::format("angular_momentum_{}", "xyz"[a])] = L[a];
  o["neighbour_builds"] = double(sys_.neighbours.builds());
  o["neighbour_pairs"] = double(sys_.neighbours.pair_count());
  o["shell_builds"] = double(sys_.shell.builds());
  o["shell_pairs"] = double(sys_.shell.built() ? sys_.shell.pair_count() : 0);
  o["shell_thickness"] = sys_.shell.thickness();
  std::vector<std::pair<std::string, double>> module_obs;
  for (const auto& m : modules_) m->observe(sys_, module_obs);
  for (const auto& [name, value] : module_obs) o[name] = value;
  if (const auto w = o.find("gravity_potential_energy"); w != o.end() && !std::isfinite(w->second))
    refuse_overflowing_sums("gravitational potential energy");
  if (analysis_) {
    const ClusterStats cs = clusters();
    const double N = double(P.size());
    o["cluster_count"] = double(cs.count);
    o["cluster_index"] = double(cs.count) / N;
    o["largest_cluster_fraction"] = cs.largest_fraction;
    o["virial_ratio"] = (kt + kr) / std::abs(o.at("gravity_potential_energy"));
    o["free_fall_time"] = free_fall_time_;
    o["time_over_free_fall"] = sys_.time / free_fall_time_;
    std::vector<Vec<D>> x;
    std::vector<double> r, m;
    for (std::size_t i = 0; i < P.size(); ++i)
      if (cs.label[i] == cs.largest) x.push_back(P.position[i]), r.push_back(P.radius[i]), m.push_back(P.mass[i]);
    o["fractal_dimension"] = fractal_dimension<D>(x, r, m);
    o["aggregation_time"] = aggregation_time_;
    // NaN while a host holds G at 0: no gravity to compare the contacts with.
    const double G = gravity_ ? gravity_->G() : 0.0;
    if (kn_ > 0) o["normalised_stiffness"] = G > 0 ? kn_ / (gravity_stiffness_per_G_ * G) : std::nan("");
  }
  if (energy_check_) check_energy(kt + kr);
  check_pass_through();   // every contact law (it reads max_overlap_ratio; none without contacts)
  if (analysis_) check_softened_core();
  if (collisions_) {
    const double n = double(collisions_->collisions()), a = double(collisions_->adhesive());
    o["collision_count"] = n;
    o["adhesive_collision_count"] = a;
    o["adhesive_collision_fraction"] = n > 0 ? a / n : std::numeric_limits<double>::quiet_NaN();
    o["open_collision_count"] = double(collisions_->open());
  }
}

template <int D>
void SimulationImpl<D>::refresh_cell_observables() const {
  auto& o = observable_values_;
  const auto& P = sys_.particles;
  const char* xyz = "xyz";
  const Tensor<D> sigma = stress();
  const double V = sys_.box.volume();
  for (int a = 0; a < D; ++a) {
    o[fmt::format("cell_length_{}", xyz[a])] = sys_.box.length[a];
    o[fmt::format("cell_strain_rate_{}", xyz[a])] = barostat_->rate()[a] / sys_.box.length[a];
    for (int b = a; b < D; ++b) o[fmt::format("stress_{}{}", xyz[a], xyz[b])] = sigma(a, b);
  }
  o["pressure"] = pressure<D>(sigma);
  o["pressure_kinetic"] = pressure<D>(kinetic_sum(nullptr) / V);
  o["pressure_reduced"] = pressure<D>(sigma) / pressure_scale_;
  o["pressure_target"] = target_reduced_;
  double solid = 0;
  for (double r : P.radius) solid += D == 3 ? 4.0 / 3 * M_PI * r * r * r : M_PI * r * r;
  o["solid_fraction"] = solid / V;
  const auto m = equilibrium_ratios();
  o["equilibrium"] = m.within({1, 1, 1, 1}) ? 1.0 : 0.0;
  o["equilibrium_force"] = m.force, o["equilibrium_torque"] = m.torque, o["equilibrium_stress"] = m.stress,
  o["equilibrium_kinetic"] = m.kinetic;
  o["inertial_time"] = inertial_time(target_reduced_);
  const auto st = barostat_->statistics();
  o["cvode_steps"] = double(st.internal_steps);
  o["cvode_rhs_evaluations"] = double(st.rhs_evaluations);
  o["cvode_reinitialisations"] = double(st.reinitialisations);
  o["cvode_seconds"] = cvode_seconds_;
}

// The four criteria as ratios to their tolerances (each below 1 passes).
template <int D>
EquilibriumMeasures SimulationImpl<D>::equilibrium_ratios() const {
  auto m = measure_equilibrium<D>(sys_.particles, stress(), barostat_->target_pressure(), force_unit_, length_unit_);
  m.force /= tolerances_.force, m.torque /= tolerances_.torque, m.stress /= tolerances_.stress,
      m.kinetic /= tolerances_.kinetic;
  return m;
}

template <int D>
void SimulationImpl<D>::refresh_bonds() const {
  observable_values_["bonded_clusters"] = double(count_bonded_clusters(sys_.particles.size(), interactions()));
}

template <int D>
void SimulationImpl<D>::refresh_network() const {
  const auto& P = sys_.particles;
  auto& o = observable_values_;
  const auto list = interactions();
  double mean_force = 0;
  for (const auto& c : list) mean_force += std::abs(c.normal_force);
  if (!list.empty()) mean_force /= double(list.size());
  const double scale = std::max(attraction_, mean_force);
  ContactNetworkOptions opt;
  opt.zero_force = zero_force_ * scale;
  opt.force_scale = attraction_ > 0 ? attraction_ : (mean_force > 0 ? mean_force : 1.0);
  opt.histogram_bins = network_bins_;
  opt.bonds_hold = attraction_ > 0;
  const ContactNetwork net = analyse_contact_network(P.size(), list, opt);
  o["coordination"] = net.z;
  o["coordination_compressive"] = net.z_plus;
  o["coordination_tensile"] = net.z_minus;
  o["coordination_zero"] = net.z_zero;
  o["rattler_fraction"] = net.rattler_fraction;
  o["backbone_coordination"] = net.z_star;
  o["distant_bonds"] = double(net.distant_bonds);
  const ContactChanges ch = compare_contacts(reference_contacts_, contact_keys(list));
  o["contacts_kept"] = double(ch.kept);
  o["contacts_lost"] = double(ch.lost);
  o["contacts_gained"] = double(ch.gained);
  for (int b = 0; b <= network_bins_; ++b) o[fmt::format("force_histogram_{:02}", b)] = net.histogram[b];
  std::vector<ElasticSpring<D>> springs;
  for (const auto& m : modules_) m->list_springs(sys_, springs);
  const YieldingContacts yielding = yielding_contacts<D>(springs);
  o["contacts_at_friction_bound"] = yielding.sliding;
  o["contacts_at_rolling_bound"] = yielding.rolling;
}

template <int D>
void SimulationImpl<D>::refresh_moduli() const {
  std::vector<ElasticSpring<D>> springs;
  for (const auto& m : modules_) m->list_springs(sys_, springs);
  double mean_force = 0;   // the contact network's zero-force threshold
  for (const auto& s : springs) mean_force += std::abs(s.normal_force);
  if (!springs.empty()) mean_force /= double(springs.size());
  ElasticModuliOptions opt;
  opt.zero_force = zero_force_ * std::max(attraction_, mean_force);
  const ElasticModuli<D> e = elastic_moduli<D>(sys_.particles.size(), sys_.box.volume(), springs, opt);
  auto& o = observable_values_;
  o["B"] = e.bulk, o["G"] = e.shear;
  const char* digits = "123";
  for (int a = 0; a < D; ++a)
    for (int b = a; b < D; ++b) o[fmt::format("C{}{}", digits[a], digits[b])] = e.stiffness(a, b);
  o["B_Voigt"] = e.bulk_voigt, o["G_Voigt"] = e.shear_voigt, o["B_Reuss"] = e.bulk_reuss, o["Z2"] = e.z2;
  o["moduli_mechanisms"] = e.mechanisms;
  o["moduli_unstable_modes"] = e.unstable_modes;
  o["moduli_floppy_modes"] = e.floppy_modes;
}

// The contact network (adhesion scenes): its interactions now.
template <int D>
std::vector<NetworkInteraction> SimulationImpl<D>::interactions() const {
  std::vector<NetworkInteraction> list;
  for (const auto& m : modules_) m->list_interactions(sys_, list);
  return list;
}

// A new mark value makes the current contacts the reference for kept / lost / gained.
template <int D>
void SimulationImpl<D>::mark_network(double value) {
  if (value == network_mark_) return;
  network_mark_ = value;
  reference_contacts_ = contact_keys(interactions());
}

// This file's members, instantiated one by one: each of the Simulation's files instantiates its own
// (a whole-class instantiation may appear in only one file of a program).
#define GRAINS_SIMULATION_OBSERVABLES_MEMBERS(D) \
  template ParticleView SimulationImpl<D>::particles() const; \
  template BoxView SimulationImpl<D>::box() const; \
  template void SimulationImpl<D>::refresh(OutputGroup) const; \
  template void SimulationImpl<D>::refresh_general() const; \
  template typename SimulationImpl<D>::MotionSums SimulationImpl<D>::motion_sums() const; \
  template void SimulationImpl<D>::check_kinetic_sums() const; \
  template std::pair<double, double> SimulationImpl<D>::kinetic_energies_scaled() const; \
  template void SimulationImpl<D>::refresh_cell_observables() const; \
  template EquilibriumMeasures SimulationImpl<D>::equilibrium_ratios() const; \
  template void SimulationImpl<D>::refresh_bonds() const; \
  template void SimulationImpl<D>::refresh_network() const; \
  template void SimulationImpl<D>::refresh_moduli() const; \
  template std::vector<NetworkInteraction> SimulationImpl<D>::interactions() const; \
  template void SimulationImpl<D>::mark_network(double);
GRAINS_SIMULATION_OBSERVABLES_MEMBERS(2)
GRAINS_SIMULATION_OBSERVABLES_MEMBERS(3)
#undef GRAINS_SIMULATION_OBSERVABLES_MEMBERS

}  // namespace grains
