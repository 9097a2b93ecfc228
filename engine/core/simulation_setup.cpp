// Building a simulation from a scene: its force modules (with the contacts' calibration), the time step and
// its checks, the neighbour lists, the pressure-controlled cell and the aggregation analysis.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <type_traits>

#include <fmt/format.h>
#include <omp.h>

#include "cell/force_unit.hpp"
#include "core/simulation_impl.hpp"
#include "interactions/contact_forces.hpp"
#include "interactions/gravity_direct.hpp"
#include "interactions/normal_calibration.hpp"
#include "interactions/pair_filter.hpp"
#include "protocols/initial_state.hpp"

namespace grains {

namespace {
// The environment variables that choose the vector code (tests and benchmarks): a misspelt or unusable one
// stops the run rather than letting it measure other code than the one asked for.
void check_environment() {
  for (const std::string& problem : {pair_filter::environment_problem(), gravity_direct::environment_problem()})
    if (!problem.empty()) throw SimulationError(problem);
}
}  // namespace

template <int D>
SimulationImpl<D>::SimulationImpl(const Scene& scene, const PreparationProgress& progress) {
  check_environment();
  auto init = make_initial_state<D>(scene, progress);
  sys_.particles = std::move(init.particles);
  sys_.box = init.box;
  for (auto& w : scene.superseded_keys()) warn(std::move(w));
  for (auto& w : init.warnings) warn(std::move(w));
  auto& P = sys_.particles;
  const std::size_t N = P.size();
  const long threads = scene.integer("run.threads");
  // Automatic: every core, but no more than one thread per 2000 particles (threads cost more than
  // they give on small systems).
  sys_.threads = threads > 0 ? int(threads) : std::clamp(int(N / 2000), 1, std::max(1, omp_get_num_procs()));
  sys_.thread_force.assign(sys_.threads, std::vector<Vec<D>>(N, Vec<D>::Zero()));
  sys_.thread_torque.assign(sys_.threads, std::vector<Spin<D>>(N, Spin<D>::Zero()));
  // The last thread's partners are all among its own particles: it never writes its slot.
  sys_.thread_force.back().clear(), sys_.thread_torque.back().clear();
  if (sys_.threads == 1) sys_.thread_force.clear(), sys_.thread_torque.clear();

  const double rmin = *std::min_element(P.radius.begin(), P.radius.end());
  const double rmax = *std::max_element(P.radius.begin(), P.radius.end());
  double tc = 0;
  if (scene.boolean("adhesion.enabled") && !scene.boolean("contact.enabled"))
    scene.fail("adhesion.enabled", "adhesion is a contact law: it needs contact.enabled = true");
  if (scene.real("rolling.coefficient") > 0 && !scene.boolean("adhesion.enabled"))
    scene.fail("rolling.coefficient", fmt::format("value {} needs the consolidation contact law: set adhesion.enabled = "
                                                  "true (adhesion.force = 0 for a cohesionless packing) or "
                                                  "rolling.coefficient = 0", scene.real("rolling.coefficient")));
  if (scene.boolean("contact.enabled")) {
    if (scene.boolean("adhesion.enabled")) {
      tc = add_adhesive_contact_module(scene);
    } else {
      tc = scene.real("contact.duration");
      add_contact_module(scene, tc);
    }
    if (scene.boolean("analysis.collision_log")) collisions_ = std::make_unique<CollisionLog<D>>();
  } else if (scene.boolean("analysis.collision_log")) {
    scene.fail("analysis.collision_log", "the collision log needs contacts: set contact.enabled = true or collision_log = false");
  }
  if (scene.boolean("gravity.enabled")) {
    if (sys_.box.any_periodic())
      scene.fail("gravity.enabled", "self-gravity needs an open box, but box.periodic = true (there are no periodic "
                                    "images of gravity): set box.periodic = false or gravity.enabled = false");
    // eps^2 enters every pair's force: it must stay finite (in range like the sizes and masses).
    const double eps = scene.real("gravity.softening") * rmin;
    if (!(eps <= 1e100))
      scene.fail("gravity.softening", fmt::format("value {:.6g} makes the softening length eps = softening * R_min = {:.3g} "
                                                  "(R_min = {:.3g}); eps must not exceed 1e100, where its square stays "
                                                  "finite: choose a smaller value", scene.real("gravity.softening"), eps, rmin));
    auto gravity = std::make_unique<SoftenedGravity<D>>(scene.real("gravity.G"), eps,
                                                        gravity_solver_from_string(scene.text("gravity.solver")),
                                                        scene.real("gravity.opening_angle"));
    gravity_ = gravity.get();
    modules_.push_back(std::move(gravity));
    setup_aggregation_analysis(scene, rmin);
  }

  contact_duration_ = tc;
  // Time step rule (physics.md section 3).
  const double nc = scene.real("time.steps_per_contact");
  if (scene.has("time.dt")) dt_ = scene.real("time.dt");
  else if (tc > 0) dt_ = tc / nc;
  else scene.fail("time.dt", "required when contacts are off (there is no contact duration to derive it from)");
  if (tc > 0 && dt_ > tc / 20)
    warn(fmt::format("time.dt = {:.6g} exceeds t_c / 20 = {:.6g} (contact duration {:.6g}): contacts are resolved by "
                     "fewer than 20 steps and restitution will be inaccurate", dt_, tc / 20, tc));
  if (tc > 0) warn_damped_packing_step(tc);
  if (tc > 0) warn_unresolved_approach(scene, rmin);
  if (tc > 0) warn_sticking_spring_step(scene, tc);
  if (tc > 0 || scene.boolean("gravity.enabled")) warn_coarse_coordinates(scene, rmin, tc > 0);
  if (scene.boolean("gravity.enabled")) warn_gravity_step(scene, rmin, tc > 0);
  // The energy check (check_energy): gravity scenes, where W is computed, without the adhesive law (whose
  // attraction's energy and parting charges it does not follow).
  energy_check_ = scene.boolean("gravity.enabled") && !scene.boolean("adhesion.enabled");

  double range = -1;
  for (const auto& m : modules_) range = std::max(range, m->pair_range());
  const double skin = scene.has("neighbours.skin") ? scene.real("neighbours.skin") : 0.4 * rmin;
  // Sorted rows for the collision log's per-pair history (the contact modules carry theirs without them).
  sys_.neighbours.configure(std::max(0.0, range), skin, bool(collisions_));
  // Without a thickness given, the shell adapts its own, starting from a tenth of the skin.
  sys_.shell.configure(scene.has("neighbours.shell") ? scene.real("neighbours.shell") : 0.1 * skin, !scene.has("neighbours.shell"), skin);
  if (sys_.shell.thickness() > 0 && sys_.shell.thickness() >= skin)
    scene.fail("neighbours.shell", fmt::format("{:.6g} is not below the skin {:.6g}: the shell selects pairs among the "
                                               "listed ones, so it must be thinner than the skin (0 turns it off)",
                                               sys_.shell.thickness(), skin));
  for (int a = 0; a < D; ++a)
    if (sys_.box.periodic[a] && 2 * rmax + std::max(0.0, range) + skin > 0.5 * sys_.box.length[a]) {
      // A given skin that alone overreaches is the skin's fault, not the box's.
      if (scene.has("neighbours.skin") && 2 * rmax + std::max(0.0, range) < 0.5 * sys_.box.length[a])
        scene.fail("neighbours.skin",
                   fmt::format("value {:.6g} is too thick for periodic axis {} ({:.6g} long): 2 R_max + interaction range "
                               "+ skin must stay within half of it, so allowed below {:.6g}", skin, a,
                               sys_.box.length[a], 0.5 * sys_.box.length[a] - 2 * rmax - std::max(0.0, range)));
      scene.fail("box.lengths", fmt::format("axis {} is {:.6g} long; a periodic box must be longer than {:.6g}, twice the "
                                            "largest interaction reach (2 R_max + interaction range + skin = {:.6g}): "
                                            "give longer lengths (derived ones grow with particles.count and fall with "
                                            "particles.solid_fraction)", a, sys_.box.length[a],
                                            2 * (2 * rmax + std::max(0.0, range) + skin),
                                            2 * rmax + std::max(0.0, range) + skin));
    }
  uses_list_ = range >= 0;
  if (scene.boolean("cell.enabled")) setup_cell(scene, 2 * rmax + std::max(0.0, range) + skin);
  orient_ = scene.boolean("particles.track_orientation");
  for (const auto& m : modules_) rotate_ |= m->applies_torques();
  for (const auto& w : sys_.particles.angular_velocity) rotate_ |= !w.isZero(0);

  rebuild();
  describe_variables(scene);
  if (rolling_)
    add_control({"rolling.damping_ratio", scene_key_unit("rolling.damping_ratio", D), Causality::parameter,
                 Variability::tunable,
                 "beta = c_r / (c_n R_i R_j) of the rolling dashpot on the relative spin (tunable: takes effect at "
                 "the next step; 0 is the paper's law)", 0.0, 1.0},
                [r = rolling_] { return r->damping; },
                [this](double beta) {
                  rolling_->damping = beta;
                  // A restored state's own value is no new setting.
                  if (!loading_controls_ && beta > 0)
                    warn_rolling_step(beta, fmt::format("rolling.damping_ratio = {:.6g} (set at t = {:.6g}, step {})", beta,
                                                        sys_.time, sys_.step));
                });
  drag_ = scene.real("drag.rate");
  add_control({"drag.rate", scene_key_unit("drag.rate", D), Causality::parameter, Variability::tunable,
               "gamma: every step multiplies velocities (relative to the cell's affine flow) and spins by "
               "exp(-gamma dt), a drag on every grain that no paper's law has: a relaxation aid (tunable: takes "
               "effect at the next step; 0 is off)", 0.0},
              [this] { return drag_; }, [this](double gamma) { drag_ = gamma; });
  if (gravity_)   // a host may steer the strength of self-gravity between steps (t_ff keeps the initial G)
    add_control({"gravity.G", scene_key_unit("gravity.G", D), Causality::parameter, Variability::tunable,
                 "gravitational constant G (tunable: takes effect at the next step; 0 switches gravity off once "
                 "initialized, while the scene itself needs G > 0)", 0.0},
                [g = gravity_] { return g->G(); },
                [this, g = gravity_](double G) {
                  // Another G moves W (and E) at once: the energy check starts again from the next value.
                  if (G != g->G()) energy_watch_.started = 0;
                  g->set_G(G);
                  // A restored state carries whether the rule has warned, and its G is no host's new value.
                  if (!loading_controls_) warn_orbit_step_at_G(G);
                });
  sys_.dt = 0, sys_.first_step = dt_;
  P.velocity_predicted = P.velocity;   // the dashpots of contacts present at the start see v(0)
  compute_forces();
  if (barostat_) contact_stress_ = contact_stress<D>(sys_.virial, sys_.box.volume());
  P.force_prev = P.force;   // a_{-1} = a_0 for the first step's velocity predictor
  check_finite("the initial state");
  track_aggregation();
  if (network_) reference_contacts_ = contact_keys(interactions());
  if (collisions_) collisions_->after_step(sys_, 0.0);   // pairs touching now start no event
}

template <int D>
void SimulationImpl<D>::add_contact_module(const Scene& scene, double tc) {
  const double e = scene.real("contact.restitution");
  const std::string mode = scene.text("contact.calibration");
  const double mstar_min = smallest_reduced_mass();
  const double fmax = scene.real("contact.overlap_limit");
  if (mode == "exact" && e < 1) {   // the clamped collision cannot realise e below its critical-damping value
    const double floor = clamped_collision(1 - 1e-12, 1.0).restitution;   // exp(-2)
    if (e <= floor)
      scene.fail("contact.restitution",
                 fmt::format("value {} is out of range for calibration = \"exact\": allowed ({:.6g}, 1] (the clamped "
                             "collision realises at least exp(-2) = {:.6g}, at critical damping); use calibration = "
                             "\"global\" or \"per-pair\" for smaller e", e, floor, floor));
  }
  SpringDashpot kc = mode == "exact" ? calibrate_exact(e, tc, mstar_min) : calibrate_linear(e, tc, mstar_min);
  if (!std::isfinite(kc.k) || !(kc.k >= std::numeric_limits<double>::min()) || !std::isfinite(kc.c)) {
    // k_n = m* C / t_c^2: overflowed to inf (no finite force) or underflowed to 0 (contacts that do not push)
    const SpringDashpot unit = mode == "exact" ? calibrate_exact(e, 1.0, 1.0) : calibrate_linear(e, 1.0, 1.0);
    scene.fail("contact.duration",
               fmt::format("value {} gives the lightest pair (m* = {:.6g}) the stiffness k_n = {:.6g}: a contact needs "
                           "a finite, nonzero stiffness, so t_c within about [{:.3g}, {:.3g}] here",
                           tc, mstar_min, kc.k,
                           std::sqrt(mstar_min * unit.k) / std::sqrt(std::numeric_limits<double>::max()) * 1.01,
                           std::sqrt(mstar_min * unit.k) / std::sqrt(std::numeric_limits<double>::min()) / 1.01));
  }
  kn_ = kc.k, cn_ = kc.c;
  if (mode == "per-pair") pair_law_scaling_ = {1.0, 1.0};   // k and c in proportion to each pair's m*
  const double mu = scene.real("friction.coefficient");
  CoulombFriction fr{mu, scene.real("friction.stiffness_ratio"), scene.real("friction.damping_ratio"), false};
  if (mode == "per-pair") {
    auto unit = calibrate_linear(e, tc, 1.0);
    LinearContactLaw<true> law{unit.k, unit.c, fmax};
    if (mu > 0) modules_.push_back(std::make_unique<ContactForces<D, LinearContactLaw<true>, CoulombFriction>>(law, fr));
    else modules_.push_back(std::make_unique<ContactForces<D, LinearContactLaw<true>, NoFriction>>(law, NoFriction{}));
  } else {
    LinearContactLaw<false> law{kc.k, kc.c, fmax};
    if (mu > 0) modules_.push_back(std::make_unique<ContactForces<D, LinearContactLaw<false>, CoulombFriction>>(law, fr));
    else modules_.push_back(std::make_unique<ContactForces<D, LinearContactLaw<false>, NoFriction>>(law, NoFriction{}));
  }
}

// The consolidation law (physics.md sections 4-6): adhesive normal law, friction bounded by the elastic
// part, optional rolling resistance. Returns the contact duration t_c = pi sqrt(m*_min / K_N) that sets dt.
template <int D>
double SimulationImpl<D>::add_adhesive_contact_module(const Scene& scene) {
  const double mstar_min = smallest_reduced_mass();
  // Left out, D0 is the paper's D0 / a = 1e-3 of the grains' size: a fixed 1e-3 would be a length in whatever units
  // the scene is written (grains of 1e-6 m would attract across a thousand diameters, in a box refused as too small
  // for that reach).
  const double a = unit_grain(scene, sys_.particles).diameter;
  AdhesiveContactLaw law{scene.real("adhesion.stiffness"), scene.real("adhesion.force"),
                         scene.has("adhesion.range") ? scene.real("adhesion.range") : 1e-3 * a,
                         damping_ratio(scene.real("adhesion.restitution")), scene.real("contact.overlap_limit")};
  refuse_unholdable_bonds(scene, law);
  adhesion_range_ = law.range;
  kn_ = law.k;
  cn_ = law.damping(2 * mstar_min, 2 * mstar_min);   // the lightest pair's c_n (m* of two masses 2 m* is m*)
  pair_law_scaling_ = {0.0, 0.5};                     // one K_N; c_n = 2 zeta sqrt(m* K_N) per pair
  network_ = true;
  attraction_ = law.attraction;
  zero_force_ = scene.real("analysis.zero_force");
  // The moduli strain the periodic cell: no outputs in an open box.
  const auto& periodic = sys_.box.periodic;
  moduli_ = scene.boolean("analysis.elastic_moduli") && std::all_of(periodic.begin(), periodic.end(), [](bool p) { return p; });
  const double mu = scene.real("friction.coefficient");
  CoulombFriction fr{mu, scene.real("friction.stiffness_ratio"), scene.real("friction.damping_ratio"), true};
  const double mu_r = scene.real("rolling.coefficient");
  // No rolling spring without rolling resistance (mu_R = 0); the rolling dashpot may still act.
  RollingResistance rr{mu_r > 0 ? scene.real("rolling.stiffness_ratio") * law.k * a * a : 0.0, mu_r,
                       scene.real("rolling.damping_ratio")};
  // In a pressure-controlled cell the rolling dashpot is switchable between steps (the tunable parameter
  // rolling.damping_ratio: the consolidation programme quenches each settled stage with it), so the
  // rolling module is built there even while it does nothing.
  const bool rolling = mu_r > 0 || rr.damping > 0 || scene.boolean("cell.enabled");
  using L = AdhesiveContactLaw;
  auto keep = [&](auto module) {
    if constexpr (std::is_same_v<std::decay_t<decltype(module->rolling())>, RollingResistance>) rolling_ = &module->rolling();
    modules_.push_back(std::move(module));
  };
  if (mu > 0 && rolling) keep(std::make_unique<ContactForces<D, L, CoulombFriction, RollingResistance>>(law, fr, rr));
  else if (mu > 0) keep(std::make_unique<ContactForces<D, L, CoulombFriction>>(law, fr));
  else if (rolling) keep(std::make_unique<ContactForces<D, L, NoFriction, RollingResistance>>(law, NoFriction{}, rr));
  else keep(std::make_unique<ContactForces<D, L, NoFriction>>(law, NoFriction{}));
  return std::numbers::pi * std::sqrt(mstar_min / law.k);
}

// A bond rests at the overlap F0 / K_N, but the clamp caps the elastic force at K_N f_max min(R_i, R_j)
// (physics.md section 2): where F0 reaches that cap no overlap balances the attraction, and the two
// smallest grains, once touching, sink through each other (two unit disks at F0 = 2 K_N f_max R ended
// with their centres 2e-4 apart and 26 times their kinetic energy, unwarned). No state of such a scene is right.
template <int D>
void SimulationImpl<D>::refuse_unholdable_bonds(const Scene& scene, const AdhesiveContactLaw& law) const {
  const double rmin = smallest_radius(), largest = largest_clamped_force(law.k, law.overlap_limit);
  if (law.attraction >= largest)
    scene.fail("adhesion.force",
               fmt::format("value {:.6g} is not below K_N f_max R_min = {:.6g}, the largest elastic force a clamped contact "
                           "gives (adhesion.stiffness K_N = {:.6g}, contact.overlap_limit f_max = {:.6g}, smallest radius "
                           "R_min = {:.6g}): a bond's rest overlap F0 / K_N = {:.6g} lies beyond the clamp f_max R_min = "
                           "{:.6g}, so bonded grains would sink through each other; allowed [0, {:.6g}) here, or raise "
                           "adhesion.stiffness or contact.overlap_limit",
                           law.attraction, largest, law.k, law.overlap_limit, rmin, law.attraction / law.k,
                           law.overlap_limit * rmin, largest));
}

// The stiffest, most violent collision: the two lightest particles.
template <int D>
double SimulationImpl<D>::smallest_reduced_mass() const {
  std::vector<double> m = sys_.particles.mass;
  std::partial_sort(m.begin(), m.begin() + std::min<std::size_t>(2, m.size()), m.end());
  return m.size() > 1 ? m[0] * m[1] / (m[0] + m[1]) : 0.5 * m[0];
}

// The pressure-controlled cell (physics.md section 9).
template <int D>
void SimulationImpl<D>::setup_cell(const Scene& scene, double list_reach) {
  const auto& P = sys_.particles;
  for (int a = 0; a < D; ++a)
    if (!sys_.box.periodic[a])
      scene.fail("cell.enabled", "a pressure-controlled cell must be periodic on every axis: set box.periodic = true");
  if (kn_ <= 0) scene.fail("cell.enabled", "the barostat needs contacts to carry the stress: set contact.enabled = true");
  // Reduced units: a = largest diameter, m = mass of a grain of diameter a, F0. Cohesionless (F0 = 0):
  // P* is P a^(D-2) / k_n.
  const UnitGrain unit = unit_grain(scene, P);
  length_unit_ = unit.diameter;
  grain_mass_ = unit.mass;
  // Without adhesion no force of the scene gives P* its unit: a fixed F0 = 1 would make the same scene written in
  // other units another pressure (forces x 1e-15: a target past the clamp, where CVODE fails).
  if (!scene.boolean("adhesion.enabled") && !scene.has("cell.force_unit"))
    scene.fail("cell.force_unit", "missing: without adhesion, give the force unit of P* in the scene's units, a value "
                                  "> 0 (P* = P a^(D-1) / value), or 0 (P* = P a^(D-2) / k_n)");
  force_unit_ = cell_force_unit(scene);
  // A subnormal unit: P* = P a^(D-1) / F0 and the time unit sqrt(a m / F0) overflow, and inf reached the outputs.
  if (force_unit_ > 0 && force_unit_ < std::numeric_limits<double>::min())
    scene.fail(scene.has("cell.force_unit") ? "cell.force_unit" : "adhesion.force",
               fmt::format("value {:.6g} as the force unit of P* is below the smallest normal double {:.6g}, where the "
                           "reduced pressure and the inertial time overflow: allowed 0 (cohesionless) or at least {:.6g}",
                           force_unit_, std::numeric_limits<double>::min(), std::numeric_limits<double>::min()));
  pressure_scale_ = force_unit_ > 0 ? force_unit_ / std::pow(length_unit_, D - 1) : kn_ / std::pow(length_unit_, D - 2);
  inertia_number_ = scene.real("cell.inertia_number");
  target_reduced_ = scene.real("cell.pressure");
  cell_active_ = scene.boolean("cell.active");
  contact_damping_ = scene.real("cell.contact_damping");
  if (force_unit_ == 0 && target_reduced_ == 0)
    scene.fail("cell.pressure", "value 0 is not allowed when cell.force_unit = 0 (cohesionless): a pressure > 0 "
                                "sets the force scale of the equilibrium test and the strain-rate cap");
  if (scene.has("cell.pressure_final")) {
    if (!scene.has("cell.ramp_duration"))
      scene.fail("cell.ramp_duration", "missing: a ramp to cell.pressure_final needs the time it takes, a value > 0");
    ramp_ = {target_reduced_, scene.real("cell.pressure_final"), sys_.time, scene.real("cell.ramp_duration"), true};
    if (force_unit_ == 0 && ramp_.to == 0)
      scene.fail("cell.pressure_final", "value 0 is not allowed when cell.force_unit = 0 (cohesionless): a value > 0");
    has_ramp_ = true;
  } else if (scene.has("cell.ramp_duration")) {
    scene.fail("cell.ramp_duration", fmt::format("value {} without cell.pressure_final: give the ramp's final P* "
                                                 "too, or drop the duration", scene.real("cell.ramp_duration")));
  }
  CellLengthParameters p;
  p.axes = D;
  // Default M_c = m (L / a)^(D-2): the contacts' damping of the cell (affine_contact_damping) and its
  // stiffness both grow like (L / a)^(D-2), so the cell's breathing mode stays about critically damped.
  const double cells = std::pow(sys_.box.length.mean() / length_unit_, D - 2), default_mass = grain_mass_ * cells;
  p.mass = scene.has("cell.mass") ? scene.real("cell.mass") : default_mass;
  const double cell_stiffness = kn_ * cells;
  p.damping = scene.real("cell.damping_ratio") * 2 * std::sqrt(p.mass * cell_stiffness);
  // The cell's breathing against the contacts, stepped with the particles' forces frozen over a step, grows every
  // step when the cell is too light for it (cell.mass = 1e-4 m blows a 100-disk cell up to Phi = 0.07). Measured
  // thresholds: 3-4e-4 in a 50-disk 2D cell, 2-5e-4 in a 100-sphere 3D cell,
  // where M_c >= k_cell dt^2 asks 5.1e-4 and 1.1e-3 (k_cell = K_N (L / a)^(D-2), the cell's stiffness scale above).
  const double lightest = cell_stiffness * dt_ * dt_;
  cell_too_light_ = p.mass < lightest;
  if (cell_too_light_)
    warn(fmt::format("cell.mass = {:.6g} is below {:.6g} = k_cell dt^2 (k_cell = K_N (L / a)^(D-2) = {:.6g}, time.dt = "
                     "{:.6g}), the lightest cell the step follows: the cell's breathing against the contacts grows every "
                     "step, held only by the strain-rate cap (cell.inertia_number) to a jitter that slows the compression, "
                     "and without it the cell blows up; raise cell.mass (unset: m (L / a)^(D-2) = {:.6g}) or lower the "
                     "step (time.steps_per_contact)", p.mass, lightest, cell_stiffness, dt_, default_mass));
  p.rate_cap = rate_cap(target_reduced_);
  // A cap so low that no run strains the cell: a force unit far below the scene's forces (T0 = sqrt(a m / F0) huge) or
  // a vanishing inertia number holds the cell still, with P* far from its target.
  if (const double steps = 0.01 / (p.rate_cap * dt_); !(steps <= 1e9))
    warn(fmt::format("cell.inertia_number = {:.6g} over T0 = sqrt(a m / F0) = {:.6g} (F0 = {:.6g}, {}) caps the cell's "
                     "strain rate at {:.6g}: at most {:.3g} of strain a step, {:.3g} steps for 1 %, so the cell cannot "
                     "follow its target pressure in any run; raise cell.inertia_number, or give the force unit the scale "
                     "of the scene's forces", inertia_number_, inertia_number_ / p.rate_cap,
                     force_unit_ > 0 ? force_unit_ : pressure_force(target_reduced_),
                     force_unit_ > 0 ? "cell.force_unit, or adhesion.force by default" : "cohesionless: P a^(D-1)",
                     p.rate_cap, p.rate_cap * dt_, steps));
  p.rtol = scene.real("cell.rtol");
  p.atol_length = scene.real("cell.atol") * length_unit_;
  p.time_unit = inertial_time(target_reduced_);
  tolerances_ = {scene.real("cell.tolerance_force"), scene.real("cell.tolerance_torque"),
                 scene.real("cell.tolerance_stress"), scene.real("cell.tolerance_kinetic")};
  clamp_force_ = largest_clamped_force(kn_, scene.real("contact.overlap_limit"));
  warn_pressure_beyond_clamp("cell.pressure", target_reduced_);
  if (has_ramp_) warn_pressure_beyond_clamp("cell.pressure_final", ramp_.to);
  barostat_ = std::make_unique<Barostat<D>>(p, sys_.box.length, target_reduced_ * pressure_scale_, sys_.time);
  if (!cell_active_) barostat_->hold();
  barostat_->restart_every_step(scene.boolean("cell.restart_cvode_every_step"));
  warn_stiff_cell_damping();
  cell_list_reach_ = list_reach;
  sys_.want_virial = true;
}

// The aggregation analysis (gravity scenes, physics.md section 8).
template <int D>
void SimulationImpl<D>::setup_aggregation_analysis(const Scene& scene, double rmin) {
  const auto& P = sys_.particles;
  analysis_ = true;
  cluster_tol_ = scene.real("analysis.cluster_tolerance") * rmin;
  aggregation_threshold_ = scene.real("analysis.aggregation_threshold");
  analysis_every_ = scene.integer("analysis.every");
  // Free-fall time from the initial state: R0 = largest distance from the centre of mass.
  double M = 0, R0 = 0;
  Vec<D> c = Vec<D>::Zero();
  for (std::size_t i = 0; i < P.size(); ++i) c += P.mass[i] * P.position[i], M += P.mass[i];
  c /= M;
  for (std::size_t i = 0; i < P.size(); ++i) R0 = std::max(R0, (P.position[i] - c).norm());
  free_fall_time_ = std::sqrt(R0 * R0 * R0 / (scene.real("gravity.G") * M));
  // Gravitational stiffness scale k_g = G m^2 / (4 R^3) (physics.md section 2) of the mean grain: the
  // contact-point attraction G m^2 / (2R)^2 of two such grains over a deformation R. Kept per unit G: a host may
  // change G while stepping, and k* follows it (t_ff, a property of the initial cloud, keeps the initial G).
  double mean_radius = 0;
  for (std::size_t i = 0; i < P.size(); ++i) mean_radius += P.radius[i];
  mean_radius /= double(P.size());
  const double mean_mass = M / double(P.size());
  gravity_stiffness_per_G_ = mean_mass * mean_mass / (4 * std::pow(mean_radius, 3));
}

// This file's members, instantiated one by one: each of the Simulation's files instantiates its own
// (a whole-class instantiation may appear in only one file of a program).
#define GRAINS_SIMULATION_SETUP_MEMBERS(D) \
  template SimulationImpl<D>::SimulationImpl(const Scene&, const PreparationProgress&); \
  template void SimulationImpl<D>::add_contact_module(const Scene&, double); \
  template double SimulationImpl<D>::add_adhesive_contact_module(const Scene&); \
  template void SimulationImpl<D>::refuse_unholdable_bonds(const Scene&, const AdhesiveContactLaw&) const; \
  template double SimulationImpl<D>::smallest_reduced_mass() const; \
  template void SimulationImpl<D>::setup_cell(const Scene&, double); \
  template void SimulationImpl<D>::setup_aggregation_analysis(const Scene&, double);
GRAINS_SIMULATION_SETUP_MEMBERS(2)
GRAINS_SIMULATION_SETUP_MEMBERS(3)
#undef GRAINS_SIMULATION_SETUP_MEMBERS

}  // namespace grains
