// SimulationImpl<D>: the one implementation of the Simulation seam, for disks (D = 2) and spheres (D = 3).
// Private to core/: its members are defined by idea in the simulation_*.cpp files beside it, each of which
// instantiates D = 2 and 3 (simulation.cpp creates it from a scene).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "analysis/clusters.hpp"
#include "analysis/collision_events.hpp"
#include "analysis/contact_network.hpp"
#include "analysis/stress.hpp"
#include "cell/barostat.hpp"
#include "cell/equilibrium.hpp"
#include "cell/pressure_ramp.hpp"
#include "core/integrator.hpp"
#include "core/orbit_step_rule.hpp"
#include "core/simulation.hpp"
#include "core/system.hpp"
#include "interactions/adhesive_contact_law.hpp"
#include "interactions/force_module.hpp"
#include "interactions/gravity.hpp"
#include "interactions/rolling_resistance.hpp"
#include "io/scene.hpp"

namespace grains {

template <int D>
class SimulationImpl final : public Simulation {
  // Outputs are computed in groups, each when one of its outputs is read (refresh).
  enum class OutputGroup : std::uint8_t { general, cell, network, bonds, moduli };

 public:
  // The modules, the cell and the time step from the scene (simulation_setup.cpp).
  explicit SimulationImpl(const Scene& scene, const PreparationProgress& progress = {});

  // The step (simulation_step.cpp).
  void step(double duration) override;
  void step_n(long n) override;
  void step_evenly(double duration, long n) override;

  double time() const override { return sys_.time; }
  long step_count() const override { return sys_.step; }
  double dt() const override { return dt_; }
  int dimension() const override { return D; }
  int threads() const override { return sys_.threads; }
  std::size_t particle_count() const override { return sys_.particles.size(); }
  const std::vector<VariableInfo>& variables() const override { return vars_; }
  const std::vector<std::string>& warnings() const override { return warnings_; }
  std::vector<CollisionEvent> collision_events() const override {
    return collisions_ ? collisions_->events() : std::vector<CollisionEvent>{};
  }

  // The variable table (simulation_variables.cpp).
  double get(std::size_t index) const override;
  void set(std::size_t index, double value) override;

  // Saved and restored state (simulation_state.cpp).
  std::vector<std::byte> save_state() const override;
  void restore_state(std::span<const std::byte> bytes) override;

  // What the writers read (simulation_observables.cpp).
  ParticleView particles() const override;
  BoxView box() const override;

 private:
  void warn(std::string w) const { warnings_.push_back(std::move(w)); }

  // An input or tunable parameter: a host sets it between steps. Register after describe_variables()
  // has listed the fixed parameters (they occupy the first entries of vars_). Its value is part of the saved
  // state; set() has checked it is finite and inside [info.min, info.max] before `set` is called.
  struct Control {
    std::function<double()> get;
    std::function<void(double)> set;
  };

  // --- set-up of the modules and the cell (simulation_setup.cpp) ---
  void add_contact_module(const Scene& scene, double tc);
  double add_adhesive_contact_module(const Scene& scene);
  void refuse_unholdable_bonds(const Scene& scene, const AdhesiveContactLaw& law) const;
  double smallest_reduced_mass() const;
  void setup_cell(const Scene& scene, double list_reach);
  void setup_aggregation_analysis(const Scene& scene, double rmin);

  double smallest_radius() const {
    const auto& r = sys_.particles.radius;
    return *std::min_element(r.begin(), r.end());
  }
  // K_N f_max R_min: the largest elastic force a clamped contact gives (physics.md section 2), which no bond's
  // attraction and no contact's share of the pressure may reach.
  double largest_clamped_force(double stiffness, double overlap_limit) const {
    return stiffness * overlap_limit * smallest_radius();
  }

  // F1 = max(F0, P a^(D-1)): the force scale of the equilibrium test and of the time unit.
  double force_scale(double reduced_pressure) const { return std::max(force_unit_, pressure_force(reduced_pressure)); }
  // P a^(D-1): the force of the pressure on a grain's face.
  double pressure_force(double reduced_pressure) const {
    return reduced_pressure * pressure_scale_ * std::pow(length_unit_, D - 1);
  }
  // T = sqrt(a m / F1) (= T0 when cohesion dominates): the time unit of the quench's drag.
  double inertial_time(double reduced_pressure) const {
    return std::sqrt(length_unit_ * grain_mass_ / force_scale(reduced_pressure));
  }
  // The strain-rate cap I_a / T0, T0 = sqrt(a m / F0) at every pressure (physics.md section 9, the paper's
  // eqs. 4-5; not I_a / T, which is sqrt(P*) times higher above P* = 1). A cohesionless cell
  // (F0 = 0) has no T0: it takes the pressure's force scale P a^(D-1), as the paper's inertia number does.
  double rate_cap(double reduced_pressure) const {
    const double force = force_unit_ > 0 ? force_unit_ : pressure_force(reduced_pressure);
    return inertia_number_ / std::sqrt(length_unit_ * grain_mass_ / force);
  }

  // --- the step (simulation_step.cpp) ---
  // Declared inline, as they were while defined in the class: only the step's file calls them, and it inlines
  // them as it did.
  template <class Steps>
  inline void run_steps(Steps steps);
  inline void settle();
  inline double time_after(double h) const;
  inline void one_step(double h, bool last, double end = std::numeric_limits<double>::quiet_NaN());
  inline double first_half(double h, bool cell_moves, const Vec<D>& scale, double& moved);
  template <class Run, class Single>
  static inline void each_run_between(const std::vector<std::uint32_t>& skip, std::size_t b, std::size_t e, Run run, Single single);
  static inline void measure_from(const typename NeighbourList<D>::Reference& reference, integrator_detail::DriftGeometry& g);
  inline void refresh_lists(double moved);
  inline double list_largest_move() const;
  inline void defer_kick(double h, double keep);
  inline double do_pending_kick();
  inline void follow_ramp();
  inline void resize_cell(const Vec<D>& scale);
  inline long clamped_now() const;
  inline Tensor<D> stress_between_steps();
  inline void check_finite_at_step(long step) const;
  // Also called at set-up and by the observables.
  void rebuild();
  void check_within_reach_of_cell() const;
  std::string blow_up_hint() const;
  Tensor<D> kinetic_sum(const PendingKick* kick) const;
  void track_aggregation();
  void check_finite(const std::string& when) const;

  void clear_forces() {
    auto& P = sys_.particles;
    std::fill(P.force.begin(), P.force.end(), Vec<D>::Zero());
    if (rotate_) std::fill(P.torque.begin(), P.torque.end(), Spin<D>::Zero());   // else nothing ever sets a torque
  }
  // `cleared`: the step's first half has already zeroed the forces, each thread its own share.
  void compute_forces(bool cleared = false) {
    if (!cleared) clear_forces();
    sys_.virial.setZero();
    for (auto& m : modules_) m->add_forces(sys_);
  }
  void clear_pending_kick() {
    auto& pending = sys_.pending_kick;
    for (const std::uint32_t p : pending.early) pending.kicked[p] = 0;
    pending.early.clear();
    pending.early_witness = 0;
    pending.active = false;
  }
  Tensor<D> stress() const { return contact_stress_ + kinetic_sum(nullptr) / sys_.box.volume(); }
  ClusterStats clusters() const {
    const auto& P = sys_.particles;
    return find_clusters<D>(P.position, P.radius, P.mass, cluster_tol_);
  }

  // --- warnings of a scene that will run badly (simulation_warnings.cpp) ---
  void warn_damped_packing_step(double tc);
  void warn_sticking_spring_step(const Scene& scene, double tc);
  // setting: what set beta, for the message (the scene's keys, or a host's or the programme's new value)
  void warn_rolling_step(double beta, const std::string& setting) const;
  void warn_coarse_coordinates(const Scene& scene, double rmin, bool contacts);
  void warn_unresolved_approach(const Scene& scene, double rmin);
  void warn_gravity_step(const Scene& scene, double rmin, bool contacts);
  std::string orbit_rule_terms(const OrbitStepRule::At& rule) const;
  void warn_orbit_step_at_G(double G);
  void warn_pressure_beyond_clamp(const char* key, double reduced_pressure);
  bool gravity_pulls() const;   // gravity on, at a G above 0
  std::string warning_time() const;   // the time of a check's warning
  void check_energy(double kinetic) const;
  void check_pass_through() const;
  void check_softened_core() const;

  // --- saved state (simulation_state.cpp) ---
  void check_loaded() const;
  void load_state(std::span<const std::byte> all);

  // --- the variable table (simulation_variables.cpp) ---
  void add_control(VariableInfo info, std::function<double()> get, std::function<void(double)> set);
  void describe_variables(const Scene& scene);
  template <class Out>
  void describe_moduli_variables(Out& out);
  template <class Out>
  void describe_cell_variables(Out& out);

  // --- observables (simulation_observables.cpp) ---
  void refresh(OutputGroup group) const;
  void refresh_general() const;
  [[noreturn]] void refuse_overflowing_sums(const char* sum) const;
  struct MotionSums {
    double translational = 0, rotational = 0;
    Vec<D> momentum = Vec<D>::Zero();
    Eigen::Vector3d angular_momentum = Eigen::Vector3d::Zero();   // about the origin; 2D: z only
  };
  MotionSums motion_sums() const;
  void check_kinetic_sums() const;
  std::pair<double, double> kinetic_energies_scaled() const;
  long kinetic_sums_checked_ = 0;   // the step of run_steps' last check_kinetic_sums (not saved: a check, no state)
  void refresh_cell_observables() const;
  EquilibriumMeasures equilibrium_ratios() const;
  void refresh_bonds() const;
  void refresh_network() const;
  void refresh_moduli() const;
  std::vector<NetworkInteraction> interactions() const;
  void mark_network(double value);

  System<D> sys_;
  std::vector<std::unique_ptr<ForceModule<D>>> modules_;
  SoftenedGravity<D>* gravity_ = nullptr;   // in modules_, when the scene has self-gravity
  RollingResistance* rolling_ = nullptr;     // the contact module's rolling parameters, when it has them
  bool uses_list_ = false, rotate_ = false;
  bool orient_ = true;   // particles.track_orientation
  double dt_ = 0, kn_ = 0, cn_ = 0;
  double contact_duration_ = 0;   // t_c (0 without contacts): the checks' advice in time.steps_per_contact
  // The gravity time-step rule's inputs (warn_gravity_step; gravity scenes of two grains or more), evaluated at the G
  // in effect by the core check and when a host sets gravity.G.
  std::optional<OrbitStepRule> orbit_rule_;
  mutable bool rolling_step_warned_ = false;   // warn_rolling_step has warned (once per run; not saved)
  bool orbit_rule_warned_ = false;   // the step exceeded the rule's, at the start-up or a host's G (once per run; saved)
  // The clock (time_after): the time of the last step that was not a whole dt (or of the start), and the
  // whole steps since.
  double clock_origin_ = 0;
  long clock_steps_ = 0;
  // A pair's k and c are kn_ (m* / m*_min)^first and cn_ (m* / m*_min)^second (global calibration: 0, 0).
  std::pair<double, double> pair_law_scaling_{0.0, 0.0};
  bool analysis_ = false;   // gravity scenes only
  double cluster_tol_ = 0, aggregation_threshold_ = 0.9, free_fall_time_ = 0, gravity_stiffness_per_G_ = 0;
  long analysis_every_ = 100;
  bool network_ = false;   // adhesion scenes: contact-network outputs
  double attraction_ = 0, adhesion_range_ = 0, zero_force_ = 1e-5, network_mark_ = 0;
  static constexpr int network_bins_ = 20;   // histogram of F_N / F0: width 0.5 from -1, plus one open bin
  std::vector<std::uint64_t> reference_contacts_;
  double aggregation_time_ = std::numeric_limits<double>::quiet_NaN();
  std::unique_ptr<CollisionLog<D>> collisions_;   // analysis.collision_log only
  std::vector<VariableInfo> vars_;
  std::vector<double> parameter_values_;   // fixed parameters: the first entries of vars_
  std::map<std::size_t, Control> controls_;  // inputs and tunable parameters, by index in vars_
  // Start-up warnings, then the run's (the energy check's, raised while outputs are computed: mutable).
  mutable std::vector<std::string> warnings_;
  bool energy_check_ = false;   // check_energy runs (gravity scenes without the adhesive law)
  // The energy check's record: the first E it saw (E_0), the lowest since and when, whether it has begun
  // and whether it has warned (once per run). Part of the saved state.
  struct EnergyWatch {
    double first = 0, minimum = 0, minimum_time = 0;
    std::uint8_t started = 0, warned = 0;
  };
  mutable EnergyWatch energy_watch_;
  mutable bool pass_through_warned_ = false;   // check_pass_through has warned (once per run; part of the saved state)
  mutable bool core_warned_ = false;           // check_softened_core has warned (once per run; part of the saved state)
  // Pressure-controlled cell (absent unless cell.enabled).
  std::unique_ptr<Barostat<D>> barostat_;
  Tensor<D> contact_stress_ = Tensor<D>::Zero();   // from the last force evaluation
  double length_unit_ = 1, force_unit_ = 1, pressure_scale_ = 1;   // a, F0, P / P*
  double grain_mass_ = 1, inertia_number_ = 0.05;                   // m of a grain of diameter a, I_a
  double target_reduced_ = 0;                       // P*, the input variable cell.pressure
  PressureRamp ramp_;                               // cell.pressure_final: the target's ramp
  bool has_ramp_ = false;                           // the scene has one (its state is then saved)
  double clamp_force_ = 0;                          // K_N f_max R_min: the most a contact's spring pushes
  bool pressure_clamp_warned_ = false;              // a target at or above clamp_force_ was warned about
  bool cell_too_light_ = false;                     // cell.mass below k_cell dt^2, warned at set-up
  bool stiff_cell_damping_warned_ = false;          // warn_stiff_cell_damping has warned (once per run; not saved)
  void warn_stiff_cell_damping();
  double cell_list_reach_ = 0;
  EquilibriumTolerances tolerances_;
  bool cell_active_ = true;
  // While load_state sets the controls: a state carries the barostat's hold or release (its restart flag and rate),
  // which cell.active's setter must not make again (it restarted CVODE after a restored state, found by fuzzing).
  bool loading_controls_ = false;
  double drag_ = 0;   // drag.rate gamma
  double contact_damping_ = 0;                       // multiplies the contacts' affine damping of the cell
  static constexpr long contact_damping_every_ = 10;  // steps between its updates (one pass over the list)
  double cvode_seconds_ = 0;
  mutable std::map<std::string, double> observable_values_;
  std::vector<OutputGroup> output_group_;                // per variable index (parameters and inputs: general)
  OutputGroup describing_ = OutputGroup::general;        // the group of the outputs being described
  struct Stamp {
    long step = -1;
    double time = -1;
  };
  mutable std::array<Stamp, 5> refreshed_{};             // when each group was last computed
  bool moduli_ = false;                                  // analysis.elastic_moduli, adhesion scenes in a periodic box
};

}  // namespace grains
