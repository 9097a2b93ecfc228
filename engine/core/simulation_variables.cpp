// The table of named variables (parameters, inputs, outputs: core/variables.hpp) that hosts read and set.
#include <cmath>
#include <map>
#include <string>

#include <fmt/format.h>

#include "core/simulation_impl.hpp"

namespace grains {

namespace {

// Units and descriptions of the force modules' observables (the modules name them; the variable lists of the
// runner's summary and the FMUs' model descriptions show these).
std::pair<const char*, const char*> module_observable_description(const std::string& name) {
  static const std::map<std::string, std::pair<const char*, const char*>> known = {
      {"contacts", {"", "pairs in contact (overlapping)"}},
      {"elastic_energy", {"J", "energy in the contact springs: sum of k_n delta^2 / 2 + k_t xi^2 / 2 + K_R theta_R^2 / 2 "
                                "(normal, tangential and rolling springs; a clamped overlap: the work of its clamped force)"}},
      {"adhesion_energy", {"J", "potential of the adhesive attraction: -F0 D0/2 (1 - h/D0)^2 across a gap h < D0, "
                                "-F0 D0/2 - F0 delta in contact"}},
      {"max_overlap_ratio", {"", "largest overlap over the smaller radius of its pair"}},
      {"clamped_contacts", {"", "contacts whose overlap exceeded contact.overlap_limit times the smaller radius in the last step"}},
      {"clamped_contacts_total", {"", "clamped_contacts summed over the steps so far (contact-steps spent clamped)"}},
      {"gravity_potential_energy", {"J", "softened gravitational potential W = -sum G m_i m_j / sqrt(d^2 + eps^2)"}},
  };
  const auto it = known.find(name);
  return it != known.end() ? it->second : std::pair<const char*, const char*>{"", "undescribed module observable"};
}

// A stress is a force per area in 3D, per length in 2D (the disks' mass is per disk, their density per area).
template <int D>
constexpr const char* stress_unit = D == 3 ? "Pa" : "N/m";

}  // namespace

template <int D>
double SimulationImpl<D>::get(std::size_t index) const {
  if (index >= vars_.size()) throw SimulationError(fmt::format("unknown variable index {}", index));
  if (auto c = controls_.find(index); c != controls_.end()) return c->second.get();
  if (index < parameter_values_.size()) return parameter_values_[index];
  refresh(index < output_group_.size() ? output_group_[index] : OutputGroup::general);
  return observable_values_.at(vars_[index].name);
}

template <int D>
void SimulationImpl<D>::set(std::size_t index, double value) {
  if (index >= vars_.size()) throw SimulationError(fmt::format("unknown variable index {}", index));
  const VariableInfo& v = vars_[index];
  const auto c = controls_.find(index);
  if (c == controls_.end())
    throw SimulationError(fmt::format("variable '{}' is a {} {}: it cannot be set after the simulation is built",
                                      v.name, to_string(v.variability), to_string(v.causality)));
  if (!std::isfinite(value) || value < v.min || value > v.max)
    throw SimulationError(fmt::format("{} = {} is not allowed: a finite value in [{}, {}]", v.name, value, v.min, v.max));
  c->second.set(value);
  for (auto& stamp : refreshed_) stamp = {};
}

template <int D>
void SimulationImpl<D>::add_control(VariableInfo info, std::function<double()> get, std::function<void(double)> set) {
  controls_.emplace(vars_.size(), Control{std::move(get), std::move(set)});
  vars_.push_back(std::move(info));
}

template <int D>
void SimulationImpl<D>::describe_variables(const Scene& scene) {
  auto param = [&](std::string name, double value, std::string unit, std::string doc) {
    vars_.push_back({std::move(name), std::move(unit), Causality::parameter, Variability::fixed, std::move(doc)});
    parameter_values_.push_back(value);
  };
  // A parameter named after a scene key has the key's unit (the schema's dimension).
  auto key_param = [&](std::string name, double value, std::string doc) {
    std::string unit = scene_key_unit(name, D);
    param(std::move(name), value, std::move(unit), std::move(doc));
  };
  key_param("particles.count", double(sys_.particles.size()), "number of particles");
  vars_.back().is_integer = true;
  key_param("scene.dimension", D, "2 = disks, 3 = spheres");
  vars_.back().is_integer = true;
  key_param("time.dt", dt_, "internal time step");
  if (network_) {
    key_param("adhesion.force", attraction_, "F0: attraction of contacting grains");
    key_param("adhesion.range", adhesion_range_, "D0: range of the attraction beyond contact");
    key_param("adhesion.restitution", scene.real("adhesion.restitution"), "e_N, sets the normal damping as if F0 = 0");
    param("contact.k_n", kn_, "N/m", "normal stiffness K_N");
    param("contact.c_n", cn_, "kg/s", "normal damping of the lightest pair");
    key_param("friction.coefficient", scene.real("friction.coefficient"), "Coulomb coefficient mu");
    key_param("rolling.coefficient", scene.real("rolling.coefficient"), "mu_R: rolling moment bound over K_N delta");
  } else if (scene.boolean("contact.enabled")) {
    key_param("contact.restitution", scene.real("contact.restitution"), "normal restitution e");
    key_param("contact.duration", scene.real("contact.duration"), "contact duration t_c");
    param("contact.k_n", kn_, "N/m", "normal stiffness (global mode: from the smallest reduced mass)");
    param("contact.c_n", cn_, "kg/s", "normal damping (global mode)");
    key_param("friction.coefficient", scene.real("friction.coefficient"), "Coulomb coefficient mu");
  }
  auto out = [&](std::string name, std::string unit, std::string doc) {
    vars_.push_back({std::move(name), std::move(unit), Causality::output, Variability::continuous, std::move(doc)});
    output_group_.resize(vars_.size(), OutputGroup::general);
    output_group_.back() = describing_;
  };
  out("time", "s", "simulated time");
  out("step", "", "internal steps taken");
  out("kinetic_energy", "J", "translational + rotational kinetic energy");
  out("translational_energy", "J", "sum of m v^2 / 2");
  out("rotational_energy", "J", "sum of I w^2 / 2");
  for (int a = 0; a < D; ++a) out(fmt::format("momentum_{}", "xyz"[a]), "kg m/s", "total linear momentum component");
  if (D == 3) {
    for (int a = 0; a < 3; ++a)
      out(fmt::format("angular_momentum_{}", "xyz"[a]), "kg m^2/s", "total angular momentum about the origin (orbital + spin), positions wrapped into the cell");
  } else {
    out("angular_momentum_z", "kg m^2/s", "total angular momentum about the origin (orbital + spin), positions wrapped into the cell");
  }
  out("neighbour_builds", "", "neighbour-list builds so far");
  out("neighbour_pairs", "", "pairs in the neighbour list");
  out("shell_builds", "", "selections of the shell of listed pairs near contact so far (neighbours.shell)");
  out("shell_pairs", "", "listed pairs in the shell the pair loop tests (0: no shell, every listed pair tested)");
  out("shell_thickness", "m", "thickness of the shell now (adaptive unless neighbours.shell is set)");
  std::vector<std::pair<std::string, double>> module_obs;
  for (const auto& m : modules_) m->observe(sys_, module_obs);
  for (const auto& [name, value] : module_obs) {
    const auto [unit, description] = module_observable_description(name);
    out(name, unit, description);
  }
  if (barostat_) {
    describing_ = OutputGroup::cell;
    describe_cell_variables(out);
    describing_ = OutputGroup::general;
  }
  if (analysis_) {
    out("cluster_count", "", "N_c: clusters of the contact graph (d < R_i + R_j + tol), isolated particles included");
    out("cluster_index", "", "N_c / N: 1 = all isolated, 1/N = one aggregate");
    out("largest_cluster_fraction", "", "f_max: mass fraction of the largest cluster");
    out("virial_ratio", "", "Q = K / |W| (0.5 at virial equilibrium)");
    out("free_fall_time", "s", "t_ff = sqrt(R0^3 / (G M)), R0 = largest initial distance from the centre of mass, G the initial one");
    out("time_over_free_fall", "", "t / t_ff");
    out("fractal_dimension", "", "mass-radius D_f of the largest cluster (NaN when it is too small)");
    out("aggregation_time", "s", "first time f_max >= analysis.aggregation_threshold, checked every analysis.every steps; NaN until then");
    if (kn_ > 0)
      out("normalised_stiffness", "", "k* = k_n / k_g, k_g = G m^2 / (4 R^3) of the mean grain (m, R) at the present G (NaN at G = 0), k_n the "
                                      "calibration's (the lightest pair's in per-pair mode)");
  }
  if (network_) {
    describing_ = OutputGroup::network;
    out("coordination", "", "z = 2 (contacts + distant bonds) / N");
    out("coordination_compressive", "", "z+: the part of z carried by compressive forces");
    out("coordination_tensile", "", "z-: the part of z carried by tensile forces (distant bonds included)");
    out("coordination_zero", "", "z0: the part of z carrying no force (|F_N| <= analysis.zero_force * max(F0, mean |F_N|))");
    out("rattler_fraction", "", "x0: fraction of rattlers: with adhesion grains with no interaction, without grains none of whose interactions carries a force");
    out("backbone_coordination", "", "z* = z / (1 - x0)");
    out("distant_bonds", "", "pairs attracting across a gap 0 <= h < D0");
    describing_ = OutputGroup::bonds;   // alone: a type-2 aggregation asks for it at every check
    out("bonded_clusters", "", "connected components of the contact + distant-bond graph (1: one aggregate holds every grain)");
    describing_ = OutputGroup::network;
    out("contacts_kept", "", "contacts (h < 0) present both now and at the last network.mark");
    out("contacts_lost", "", "contacts at the last network.mark that are open now");
    out("contacts_gained", "", "contacts now that were open at the last network.mark");
    out("contacts_at_friction_bound", "", "fraction of the frictional contacts whose |F_T| is at mu F_N^e (to 1e-6): ready to "
                                          "slide (the consolidation paper finds none in equilibrium); NaN without friction");
    out("contacts_at_rolling_bound", "", "fraction of the contacts with a rolling spring whose |Gamma_R| is at mu_R F_N^e (to "
                                         "1e-6): ready to roll; NaN without rolling resistance");
    // Each bin says its own range: only the first bin also holds what is below.
    for (int b = 0; b <= network_bins_; ++b)
      out(fmt::format("force_histogram_{:02}", b), "",
          fmt::format("fraction of interactions with F_N / F0 {} (static normal force; F0 = 0: over the mean |F_N|)",
                      b == 0               ? fmt::format("below {:g}: the bin [-1, {:g}) and everything below it", -0.5, -0.5)
                      : b < network_bins_ ? fmt::format("in [{:g}, {:g})", -1 + 0.5 * b, -0.5 + 0.5 * b)
                                           : fmt::format(">= {:g}", -1 + 0.5 * network_bins_)));
    describing_ = OutputGroup::moduli;
    if (moduli_) describe_moduli_variables(out);
    describing_ = OutputGroup::general;
    VariableInfo mark{"network.mark", "", Causality::input, Variability::discrete,
                      "setting a new value makes the current contacts the reference of contacts_kept / lost / gained "
                      "(e.g. the stage number of a compression programme)"};
    add_control(mark, [this] { return network_mark_; }, [this](double v) { mark_network(v); });
  }
  if (collisions_) {
    out("collision_count", "", "completed contact events (analysis.collision_log)");
    out("adhesive_collision_count", "", "completed events that ended with the pair still touching (no rebound)");
    out("adhesive_collision_fraction", "", "adhesive_collision_count / collision_count (NaN before the first)");
    out("open_collision_count", "", "contact events still in progress");
  }
}

// Elastic moduli (analysis/elastic_moduli.hpp), computed only when one of them is read.
template <int D>
template <class Out>
void SimulationImpl<D>::describe_moduli_variables(Out& out) {
  out("B", stress_unit<D>, "bulk modulus of the contact network: sum_ab C_ab / D^2 (2D: (C11 + C12) / 2)");
  out("G", stress_unit<D>, "shear modulus for the cell's pure shears: (tr C - sum_ab C_ab / D) / (2 (D - 1)) (2D: (C11 - C12) / 2)");
  const char* digits = "123";
  for (int a = 0; a < D; ++a)
    for (int b = a; b < D; ++b)
      out(fmt::format("C{}{}", digits[a], digits[b]), stress_unit<D>,
          "stiffness d sigma_a / d eps_b over the cell's diagonal strains (the inverse of the compliance)");
  out("B_Voigt", stress_unit<D>, "Voigt bulk modulus: every grain follows the strain affinely without rotating (an upper bound of B)");
  out("G_Voigt", stress_unit<D>, "Voigt shear modulus (an upper bound of G)");
  out("B_Reuss", stress_unit<D>, "Reuss estimate: force increments proportional to the static forces, V P^2 / sum (F_N^2/K_N + F_T^2/K_T + Gamma^2/K_R)");
  out("Z2", "", "<F_N^2 + (K_N/K_T) F_T^2 + (K_N/K_R) Gamma^2> / <F_N>^2 over the interactions carrying force");
  out("moduli_mechanisms", "", "strain directions the contact network does not resist (B or G is then 0 within round-off)");
  out("moduli_unstable_modes", "", "negative stiffness directions (distant bonds' -F0/D0 not held): the moduli are then NaN");
  out("moduli_floppy_modes", "", "zero modes of the grains at fixed strain (rigid translations, rolling on one contact, ...)");
}

template <int D>
template <class Out>
void SimulationImpl<D>::describe_cell_variables(Out& out) {
  const char* xyz = "xyz";
  for (int a = 0; a < D; ++a) out(fmt::format("cell_length_{}", xyz[a]), "m", "periodic cell length L");
  for (int a = 0; a < D; ++a) out(fmt::format("cell_strain_rate_{}", xyz[a]), "1/s", "(dL/dt) / L");
  for (int a = 0; a < D; ++a)
    for (int b = a; b < D; ++b)
      out(fmt::format("stress_{}{}", xyz[a], xyz[b]), stress_unit<D>,
          "stress tensor, contact + kinetic, compressive positive: sum of F_a r_b / V over the contacts + sum of "
          "m v_a v_b / V (off the diagonal a < b only: the contacts' net moments, zero in equilibrium, can make the b-a "
          "entry differ in motion)");
  out("pressure", stress_unit<D>, "trace(stress) / D, contact + kinetic");
  out("pressure_kinetic", stress_unit<D>, "kinetic part of the pressure (velocities relative to the affine flow)");
  // This scene's P*: a cohesionless cell (F0 = 0) reduces by k_n (setup_cell's pressure_scale_).
  const std::string reduced = force_unit_ > 0 ? (D == 3 ? "a^2 P / F0" : "a P / F0")
                                              : (D == 3 ? "a P / k_n (cohesionless, F0 = 0)" : "P / k_n (cohesionless, F0 = 0)");
  out("pressure_reduced", "", "P* of the current stress: " + reduced);
  out("pressure_target", "", "P* the barostat drives the stress to: cell.pressure, or with a ramp (cell.pressure_final) its value at "
      "the start of the last step");
  out("solid_fraction", "", "Phi: grain area (2D) or volume (3D) over the cell's");
  out("equilibrium", "", "1 when all four equilibrium criteria hold (physics.md section 9), else 0");
  out("equilibrium_force", "", "largest net force / (tolerance_force F1): below 1 passes");
  out("equilibrium_torque", "", "largest net torque / (tolerance_torque F1 a): below 1 passes");
  out("equilibrium_stress", "", "largest |sigma_aa - P| / (tolerance_stress F1 / a^(D-1)): below 1 passes");
  out("equilibrium_kinetic", "", "kinetic energy per grain / (tolerance_kinetic F1 a): below 1 passes");
  out("inertial_time", "s", "T = sqrt(a m / F1), F1 = max(F0, P a^(D-1)) at the target pressure: the time unit of "
      "programme.quench_drag (the strain-rate cap's is T0, from F0 alone)");
  out("cvode_steps", "", "CVODE internal steps of the cell-length equations so far");
  out("cvode_rhs_evaluations", "", "CVODE right-hand-side evaluations so far");
  out("cvode_reinitialisations", "", "CVODE restarts (a new target pressure, a released cell, and one every 500 particle steps: a saved state carries the steps since the last)");
  out("cvode_seconds", "s", "wall time spent in CVODE (this process)");
  add_control({"cell.pressure", scene_key_unit("cell.pressure", D), Causality::input, Variability::continuous,
               "target reduced pressure P* = " + reduced, 0, 1e6},
              [this] { return target_reduced_; },
              [this](double v) {
                if (force_unit_ == 0 && v == 0)
                  throw SimulationError("cell.pressure = 0 is not allowed when cell.force_unit = 0 (cohesionless): "
                                        "a finite value > 0");
                warn_pressure_beyond_clamp("cell.pressure", v);
                target_reduced_ = v;
                ramp_.on = false;   // the host (or the programme) drives the pressure now
                barostat_->set_target_pressure(v * pressure_scale_, rate_cap(v));
              });
  VariableInfo active{"cell.active", scene_key_unit("cell.active", D), Causality::input, Variability::discrete,
                      "1: the barostat moves the cell; 0: the cell is held fixed at rest (e.g. while a type-2 sample "
                      "aggregates)", 0, 1};
  active.is_integer = true;
  add_control(active, [this] { return cell_active_ ? 1.0 : 0.0; },
              [this](double v) {
                if (v != 0 && v != 1) throw SimulationError(fmt::format("cell.active = {} is not allowed: 0 or 1", v));
                if ((v == 1) == cell_active_) return;   // unchanged (a restored state sets every control)
                cell_active_ = v == 1;
                if (loading_controls_) return;   // the restored barostat is held or released already
                if (cell_active_) {
                  barostat_->release();
                  warn_stiff_cell_damping();
                } else {
                  barostat_->hold();
                }
              });
}

// This file's members, instantiated one by one: each of the Simulation's files instantiates its own
// (a whole-class instantiation may appear in only one file of a program).
#define GRAINS_SIMULATION_VARIABLES_MEMBERS(D) \
  template double SimulationImpl<D>::get(std::size_t) const; \
  template void SimulationImpl<D>::set(std::size_t, double); \
  template void SimulationImpl<D>::add_control(VariableInfo, std::function<double()>, std::function<void(double)>); \
  template void SimulationImpl<D>::describe_variables(const Scene&);
GRAINS_SIMULATION_VARIABLES_MEMBERS(2)
GRAINS_SIMULATION_VARIABLES_MEMBERS(3)
#undef GRAINS_SIMULATION_VARIABLES_MEMBERS

}  // namespace grains
