#include "core/simulation.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <type_traits>

#include <fmt/format.h>
#include <omp.h>

#include "analysis/clusters.hpp"
#include "analysis/bonded_clusters.hpp"
#include "analysis/contact_network.hpp"
#include "analysis/elastic_moduli.hpp"
#include "analysis/collision_events.hpp"
#include "analysis/fractal_dimension.hpp"
#include "analysis/stress.hpp"
#include "cell/affine_contact_damping.hpp"
#include "cell/barostat.hpp"
#include "cell/equilibrium.hpp"
#include "cell/force_unit.hpp"
#include "cell/pressure_ramp.hpp"
#include "core/dashpot_stability.hpp"
#include "core/integrator.hpp"
#include "core/system.hpp"
#include "interactions/adhesive_contact_law.hpp"
#include "interactions/contact_forces.hpp"
#include "interactions/gravity.hpp"
#include "interactions/normal_calibration.hpp"
#include "io/scene.hpp"
#include "protocols/initial_state.hpp"

namespace grains {

std::size_t Simulation::index_of(const std::string& name) const {
  const auto& v = variables();
  for (std::size_t i = 0; i < v.size(); ++i)
    if (v[i].name == name) return i;
  throw SimulationError(fmt::format("unknown variable '{}'", name));
}

namespace {

// Units and descriptions of the force modules' observables (the modules name them; the variable lists of the
// runner's summary and the FMUs' model descriptions show these).
std::pair<const char*, const char*> module_observable_description(const std::string& name) {
  static const std::map<std::string, std::pair<const char*, const char*>> known = {
      {"contacts", {"", "pairs in contact (overlapping)"}},
      {"elastic_energy", {"J", "energy in the contact springs: sum of k_n delta^2 / 2 + k_t xi^2 / 2 (a clamped overlap: "
                                "the work of its clamped force)"}},
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

template <int D>
class SimulationImpl final : public Simulation {
  // Outputs are computed in groups, each when one of its outputs is read (refresh).
  enum class OutputGroup : std::uint8_t { general, cell, network, bonds, moduli };

 public:
  explicit SimulationImpl(const Scene& scene) {
    auto init = make_initial_state<D>(scene);
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
    if (tc > 0) warn_coarse_coordinates(scene, rmin);
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
      add_control({"rolling.damping_ratio", "", Causality::parameter, Variability::tunable,
                   "beta = c_r / (c_n R_i R_j) of the rolling dashpot on the relative spin (tunable: takes effect at "
                   "the next step; 0 is the paper's law)", 0.0, 1.0},
                  [r = rolling_] { return r->damping; }, [r = rolling_](double beta) { r->damping = beta; });
    drag_ = scene.real("drag.rate");
    add_control({"drag.rate", "1/s", Causality::parameter, Variability::tunable,
                 "gamma: every step multiplies velocities (relative to the cell's affine flow) and spins by "
                 "exp(-gamma dt), a drag on every grain that no paper's law has: a relaxation aid (tunable: takes "
                 "effect at the next step; 0 is off)", 0.0},
                [this] { return drag_; }, [this](double gamma) { drag_ = gamma; });
    if (gravity_)   // a host may steer the strength of self-gravity between steps (t_ff keeps the initial G)
      add_control({"gravity.G", "", Causality::parameter, Variability::tunable,
                   "gravitational constant G (tunable: takes effect at the next step; 0 switches gravity off once "
                   "initialized, while the scene itself needs G > 0)", 0.0},
                  [g = gravity_] { return g->G(); },
                  [this, g = gravity_](double G) {
                    // Another G moves W (and E) at once: the energy check starts again from the next value.
                    if (G != g->G()) energy_watch_.started = 0;
                    g->set_G(G);
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

  void step(double duration) override {
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
  void step_n(long n) override {
    run_steps([&] {
      for (long k = 0; k < n; ++k) one_step(dt_, k == n - 1);
    });
  }
  void step_evenly(double duration, long n) override {
    if (!(duration > 0) || !std::isfinite(duration) || n < 1 || duration / double(n) > dt_ * (1 + 1e-12))
      throw SimulationError(fmt::format("step_evenly: {} equal steps of {} are not allowed: finite, positive, at most dt = {}",
                                        n, duration / double(n), dt_));
    const double target = sys_.time + duration, h = duration / double(n);
    run_steps([&] {
      for (long k = 0; k < n - 1; ++k) one_step(h, false);
      one_step(target - sys_.time, true, target);
    });
  }

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

  double get(std::size_t index) const override {
    if (index >= vars_.size()) throw SimulationError(fmt::format("unknown variable index {}", index));
    if (auto c = controls_.find(index); c != controls_.end()) return c->second.get();
    if (index < parameter_values_.size()) return parameter_values_[index];
    refresh(index < output_group_.size() ? output_group_[index] : OutputGroup::general);
    return observable_values_.at(vars_[index].name);
  }
  void set(std::size_t index, double value) override {
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

  // First word of a saved state: "GRN" and a version, raised whenever the layout changes (version 2: the
  // 2D tangential spring became one number per pair; 3: no previous angular accelerations, which only an
  // unused spin prediction read; 4: the drag.rate control; 5: no angular accelerations, which the torques
  // give; 6: the previous force instead of both accelerations; 7: the shell of pairs near contact; a scene with
  // a pressure ramp, new since, appends the ramp's on flag, and one with cell.contact_damping > 0 then the cell's
  // contact damping; 8: a check sum ends the state, the clock's origin and whole steps follow the step count; 9: the
  // adhesive contacts' parting charges of the last evaluation; 10: a gravity scene's energy check follows its
  // aggregation time; 11: the barostat's last stress, which its next step extrapolates from; 12: the particles' periodic
  // images, after their orientations; 13: whether the clamp warning was given, after the barostat's stress).
  // States of builds before the word start with D (2, 3).
  static constexpr std::uint32_t state_format = 0x47524e0d;

  std::vector<std::byte> save_state() const override {
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
  // What a loaded state's indices address must exist: the lists' rows are the particles, the shell's entries
  // the list's, the modules' per-pair arrays the list's pairs.
  void check_loaded() const {
    const std::size_t N = sys_.particles.size();
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
  void restore_state(std::span<const std::byte> bytes) override {
    const auto backup = save_state();
    try {
      load_state(bytes);
    } catch (const std::exception& e) {
      load_state(backup);
      throw SimulationError(fmt::format("restore_state: {}; the simulation is unchanged", e.what()));
    }
  }

 private:
  void load_state(std::span<const std::byte> all) {
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
    }
    if (network_) r.get_vector(reference_contacts_), network_mark_ = r.get<double>();
    if (barostat_) {
      barostat_->load(r);
      contact_stress_ = r.get<Tensor<D>>();
      pressure_clamp_warned_ = r.get<std::uint8_t>() != 0;
      sys_.box.length = barostat_->length();
    }
    if (collisions_) collisions_->load(r);
    for (auto& [index, c] : controls_) c.set(r.get<double>());   // the network mark is unchanged: no new reference
    if (has_ramp_) ramp_.on = r.get<bool>();
    if (barostat_ && contact_damping_ > 0) barostat_->set_contact_damping(r.get<Vec<D>>());
    if (!r.done()) throw SimulationError("the saved state has trailing bytes (another scene?)");
    check_loaded();
    for (auto& stamp : refreshed_) stamp = {};
  }

 public:
  ParticleView particles() const override {
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
  BoxView box() const override {
    BoxView b;
    b.dimension = D;
    for (int a = 0; a < D; ++a) {
      b.lower.push_back(sys_.box.lower[a]);
      b.length.push_back(sys_.box.length[a]);
      b.periodic.push_back(sys_.box.periodic[a]);
    }
    return b;
  }

 private:
  void warn(std::string w) const { warnings_.push_back(std::move(w)); }

  // An input or tunable parameter: a host sets it between steps. Register after describe_variables()
  // has listed the fixed parameters (they occupy the first entries of vars_). Its value is part of the saved
  // state; set() has checked it is finite and inside [info.min, info.max] before `set` is called.
  struct Control {
    std::function<double()> get;
    std::function<void(double)> set;
  };
  void add_control(VariableInfo info, std::function<double()> get, std::function<void(double)> set) {
    controls_.emplace(vars_.size(), Control{std::move(get), std::move(set)});
    vars_.push_back(std::move(info));
  }

  void add_contact_module(const Scene& scene, double tc) {
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
  double add_adhesive_contact_module(const Scene& scene) {
    const double mstar_min = smallest_reduced_mass();
    AdhesiveContactLaw law{scene.real("adhesion.stiffness"), scene.real("adhesion.force"), scene.real("adhesion.range"),
                           damping_ratio(scene.real("adhesion.restitution")), scene.real("contact.overlap_limit")};
    refuse_unholdable_bonds(scene, law);
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
    const double a = unit_grain(scene, sys_.particles).diameter;
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
  void refuse_unholdable_bonds(const Scene& scene, const AdhesiveContactLaw& law) const {
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

  double smallest_radius() const {
    const auto& r = sys_.particles.radius;
    return *std::min_element(r.begin(), r.end());
  }
  // K_N f_max R_min: the largest elastic force a clamped contact gives (physics.md section 2), which no bond's
  // attraction and no contact's share of the pressure may reach.
  double largest_clamped_force(double stiffness, double overlap_limit) const {
    return stiffness * overlap_limit * smallest_radius();
  }

  // The stiffest, most violent collision: the two lightest particles.
  double smallest_reduced_mass() const {
    std::vector<double> m = sys_.particles.mass;
    std::partial_sort(m.begin(), m.begin() + std::min<std::size_t>(2, m.size()), m.end());
    return m.size() > 1 ? m[0] * m[1] / (m[0] + m[1]) : 0.5 * m[0];
  }

  // --- contact network (adhesion scenes) ---
  std::vector<NetworkInteraction> interactions() const {
    std::vector<NetworkInteraction> list;
    for (const auto& m : modules_) m->list_interactions(sys_, list);
    return list;
  }
  // A new mark value makes the current contacts the reference for kept / lost / gained.
  void mark_network(double value) {
    if (value == network_mark_) return;
    network_mark_ = value;
    reference_contacts_ = contact_keys(interactions());
  }

  // --- pressure-controlled cell (physics.md section 9) ---
  void setup_cell(const Scene& scene, double list_reach) {
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
    force_unit_ = cell_force_unit(scene);
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
    p.mass = scene.has("cell.mass") ? scene.real("cell.mass")
                                    : grain_mass_ * std::pow(sys_.box.length.mean() / length_unit_, D - 2);
    const double cell_stiffness = kn_ * std::pow(sys_.box.length.mean() / length_unit_, D - 2);
    p.damping = scene.real("cell.damping_ratio") * 2 * std::sqrt(p.mass * cell_stiffness);
    p.rate_cap = rate_cap(target_reduced_);
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
    cell_list_reach_ = list_reach;
    sys_.want_virial = true;
  }

  // A contact of the pressed packing carries about the pressure's force P a^(D-1); the clamp caps its elastic
  // force at K_N f_max R_min (physics.md section 2), so a target at or above that cannot be held: the cell
  // shrinks until the grains sit inside each other (64 disks at P* = 2e4, twice the cap, reached Phi = 1.13
  // with overlaps past a radius and no warning) or it stops the run as too small. Warned, not refused: the
  // force a contact takes depends on the packing, and collapse begins below the cap (one contact in a few
  // carries several times the mean).
  // Once per simulation: a programme or a host raising the pressure stage by stage would repeat it.
  void warn_pressure_beyond_clamp(const char* key, double reduced_pressure) {
    const double force = pressure_force(reduced_pressure);
    if (pressure_clamp_warned_ || force < clamp_force_) return;
    pressure_clamp_warned_ = true;
    warn(fmt::format("{} = {:.6g} asks each contact for about P a^(D-1) = {:.6g}, not below {:.6g}, the largest elastic "
                     "force a clamped contact gives (K_N contact.overlap_limit R_min): the packing cannot hold this pressure "
                     "and collapses into overlaps past the clamp; keep P* below {:.6g}, or raise the contacts' stiffness or "
                     "contact.overlap_limit", key, reduced_pressure, force, clamp_force_,
                     reduced_pressure * clamp_force_ / force));
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
  // eqs. 4-5; until 2026-12-04 it was I_a / T, sqrt(P*) times higher above P* = 1). A cohesionless cell
  // (F0 = 0) has no T0: it takes the pressure's force scale P a^(D-1), as the paper's inertia number does.
  double rate_cap(double reduced_pressure) const {
    const double force = force_unit_ > 0 ? force_unit_ : pressure_force(reduced_pressure);
    return inertia_number_ / std::sqrt(length_unit_ * grain_mass_ / force);
  }

  // The ramp's target for the step about to be taken (frozen over it, like the stress).
  void follow_ramp() {
    target_reduced_ = ramp_.at(sys_.time);
    if (ramp_.ended(sys_.time)) ramp_.on = false;
    barostat_->follow_target_pressure(target_reduced_ * pressure_scale_, rate_cap(target_reduced_));
  }

  // The cell takes its new lengths: the list's image shifts follow, and a cell too small for its
  // particles stops the run. The particles follow in the step's first pass (DriftGeometry::follow).
  void resize_cell(const Vec<D>& scale) {
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
            clamped > 0 ? fmt::format(" (or, since {} contacts are clamped now, overlapping past contact.overlap_limit, "
                                      "a lower pressure: the contacts cannot carry this one)", clamped)
                        : std::string()));
      }
  }
  // Contacts clamped at the last force evaluation (the contact module's observable; 0 without contacts).
  long clamped_now() const {
    std::vector<std::pair<std::string, double>> out;
    for (const auto& m : modules_) m->observe(sys_, out);
    for (const auto& [name, value] : out)
      if (name == "clamped_contacts") return long(value);
    return 0;
  }
  Tensor<D> stress() const { return contact_stress_ + kinetic_sum(nullptr) / sys_.box.volume(); }
  // The stress the barostat reads between the steps of a run: while the last kick is pending, its
  // kinetic part is that of the velocities the kick will give (bit for bit: integrator.hpp).
  Tensor<D> stress_between_steps() {
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
  Tensor<D> kinetic_sum(const PendingKick* kick) const {
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
#pragma omp parallel num_threads(T)
    add_share(omp_get_thread_num(), omp_get_num_threads(), part[std::size_t(omp_get_thread_num())]);
    Tensor<D> sum = part[0];
    for (std::size_t t = 1; t < part.size(); ++t) sum += part[t];
    return sum;
  }

  void rebuild() {
    if (!uses_list_) return;
    auto& P = sys_.particles;
    for (const auto& x : P.position)   // never grid a non-finite position
      if (!x.allFinite()) check_finite_at_step(sys_.step + 1);
    for (std::size_t i = 0; i < P.size(); ++i) P.position[i] = sys_.box.wrap(P.position[i], &P.image[i]);
    sys_.neighbours.build(P.position, P.radius, sys_.box, sys_.threads);
    if (sys_.shell.enabled()) sys_.shell.build(sys_.neighbours, P.position, P.radius, 0.0, sys_.step, false);
    for (auto& m : modules_) m->after_rebuild(sys_.neighbours);
    if (collisions_) collisions_->after_rebuild(sys_.neighbours);
  }

  // After a step's first pass: rebuilds the list where it is stale, else the shell where it is (or
  // where it is not built yet). `moved` is the largest squared move the pass measured: from the shell's
  // reference positions if the shell is built, else from the list's. The list is rebuilt exactly when
  // it would be without a shell: by its own measure, taken where the shell's bound cannot rule it out.
  void refresh_lists(double moved) {
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

  // The moves are measured from `reference` (a list's or the shell's), as the cell has carried it.
  static void measure_from(const typename NeighbourList<D>::Reference& reference, integrator_detail::DriftGeometry& g) {
    g.reference = reinterpret_cast<const double*>(reference.position);
    g.carried = reference.strain != Vec<D>::Ones();
    for (int a = 0; a < D; ++a) g.reference_lower[a] = reference.lower[a], g.strain[a] = reference.strain[a];
  }

  // The largest squared move from the list's reference positions, as the first pass would have
  // measured it against them (infinite for a list of another particle count).
  double list_largest_move() const {
    const auto& P = sys_.particles;
    const auto reference = sys_.neighbours.reference(P.size());
    if (!reference.position) return std::numeric_limits<double>::infinity();
    integrator_detail::DriftGeometry g;
    measure_from(reference, g);
    const double* x = reinterpret_cast<const double*>(P.position.data());
    return D == 2 ? integrator_detail::largest_move_2(P.size(), x, g) : integrator_detail::largest_move_3(P.size(), x, g);
  }

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

  // Kick, drift and predict; follow the cell; measure how far the particles moved since the list was
  // built; clear the forces: all per particle, so one pass does them, each thread its own share
  // (core/thread_share.hpp), in one parallel region. On a few thousand particles a step takes some tens
  // of microseconds, and every region that opens and joins costs a few of them. Returns the integrator's
  // witness.
  double first_half(double h, bool cell_moves, const Vec<D>& scale, double& moved) {
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
  template <class Run, class Single>
  static void each_run_between(const std::vector<std::uint32_t>& skip, std::size_t b, std::size_t e, Run run, Single single) {
    std::size_t from = b;
    for (auto it = std::lower_bound(skip.begin(), skip.end(), std::uint32_t(b)); it != skip.end() && *it < e; ++it) {
      if (*it > from) run(from, std::size_t(*it));
      single(std::size_t(*it));
      from = std::size_t(*it) + 1;
    }
    if (from < e) run(from, e);
  }

  void clear_pending_kick() {
    auto& pending = sys_.pending_kick;
    for (const std::uint32_t p : pending.early) pending.kicked[p] = 0;
    pending.early.clear();
    pending.early_witness = 0;
    pending.active = false;
  }

  // Leaves a step's second half kick pending for the next step's first pass (core/pending_kick.hpp).
  void defer_kick(double h, double keep) {
    auto& pending = sys_.pending_kick;
    pending.kicked.resize(sys_.particles.size(), 0);
    pending.active = true, pending.h = h, pending.keep = keep, pending.spins = rotate_;
  }

  // Does the pending kick (on every particle not kicked early, each thread its share); returns the sum of
  // the kicked velocities and spins (finite exactly when every one is).
  double do_pending_kick() {
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

  // Nothing is pending between runs: a run's last kick is done before it returns.
  void settle() {
    if (!std::isfinite(do_pending_kick())) check_finite_at_step(sys_.step);
  }

  // Runs steps with each step's second half kick deferred to the next one's first pass where nothing
  // reads the velocities between steps; the last kick is done before returning (also on an error).
  template <class Steps>
  void run_steps(Steps steps) {
    try {
      steps();
    } catch (...) {
      try { settle(); } catch (...) {}   // the first error is the one to report
      throw;
    }
    settle();
  }

  // The time after a step of h: a whole step's is the clock's origin plus the whole steps since, times dt
  // (one rounding, however long the run: a sum of dt drifted from a host's own clock by ~1e-16 t per step);
  // a shorter step's (a host's remainder) is the clock's new origin.
  double time_after(double h) const {
    return h == dt_ ? clock_origin_ + double(clock_steps_ + 1) * dt_ : sys_.time + h;
  }

  // `last`: the run's last step, after which a host, an observer or a moving cell may read the stress.
  // `end`: where the step lands (a remainder step's target), else time_after(h).
  void one_step(double h, bool last, double end = std::numeric_limits<double>::quiet_NaN()) {
    const double t_end = std::isnan(end) ? time_after(h) : end;
    Vec<D> scale = Vec<D>::Ones();
    const bool cell_moves = barostat_ && cell_active_;
    // The contact virial is summed where the stress will be read: for the barostat at every step while
    // the cell moves, else after the run's last step (a held cell, as in a type-2 aggregation, saves it).
    sys_.want_virial = barostat_ && (cell_moves || last);
    if (barostat_ && ramp_.on) follow_ramp();
    if (cell_moves) {   // the cell moves under the stress of the last force evaluation (operator splitting)
      if (contact_damping_ > 0 && sys_.step % contact_damping_every_ == 0)
        barostat_->set_contact_damping(contact_damping_ * affine_contact_damping<D>(sys_, cn_));
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

  // Damped-packing time-step rule (core/dashpot_stability.hpp): the lightest grain pressed on all sides,
  // by 12 contacts in 3D or 6 in 2D, against neighbours of the next lightest mass or of the heaviest one. Along any
  // axis its springs and dashpots add up to z / D of one contact's (cos^2 of the contact directions
  // averages 1 / D), and the fastest mode moves neighbours against each other, which the pair's reduced
  // mass m* carries: w^2 = (z k / D) / m* (equal masses: twice the rate of a grain between fixed walls;
  // a light grain among heavy ones: m* -> its mass). Above the limit that mode grows (a dense aggregate of
  // 1000 spheres at zeta = 0.9 kept 40 times the kinetic energy at 20 steps per contact that it kept at
  // 100; an FCC crystal is tested against the rule).
  void warn_damped_packing_step(double tc) {
    const auto& m = sys_.particles.mass;
    if (m.empty() || !(kn_ > 0) || !(cn_ > 0)) return;
    std::vector<double> sorted = m;
    std::partial_sort(sorted.begin(), sorted.begin() + std::min<std::size_t>(2, sorted.size()), sorted.end());
    const double lightest = sorted[0];
    const double heaviest = *std::max_element(m.begin(), m.end());
    const double z = D == 3 ? 12 : 6, mstar_min = smallest_reduced_mass();
    double limit = std::numeric_limits<double>::infinity(), worst_zeta = 0;
    // its partners: the next lightest grain (its own mass in a monodisperse packing) and the heaviest
    for (double neighbour : {sorted.size() > 1 ? sorted[1] : sorted[0], heaviest}) {
      const double mstar = lightest * neighbour / (lightest + neighbour);
      const double k = kn_ * std::pow(mstar / mstar_min, pair_law_scaling_.first);
      const double c = cn_ * std::pow(mstar / mstar_min, pair_law_scaling_.second);
      const double K = z * k / D, C = z * c / D, w = std::sqrt(K / mstar), zeta = C / (2 * std::sqrt(K * mstar));
      if (const double h = predicted_dashpot_limit(zeta) / w; h < limit) limit = h, worst_zeta = zeta;
    }
    // One contact of the lightest pair alone: its spring's undamped frequency w0 = sqrt(k_n / m*) = sqrt(pi^2 + ln^2 e) / t_c
    // grows without bound as e -> 0 at a fixed t_c, which the t_c / 20 rule (on the damped half-period) does not
    // see. Measured against the clamped law's restitution, head-on: the error is 1e-3 to 2.5e-3 at w0 dt = 0.14-0.15
    // whatever e (1e-3, 1e-6, 1e-20), 2 % at 0.185, 5 % at 0.283 (e = 1e-6, 50 steps per contact), and past the stable
    // step, 0.28 / w0 here, it is garbage (e = 1e-20 at 50 steps: 0.028 against 0.136; 1e-100: 39 times the energy).
    // So the rule's resolution, pi / 20, is asked of w0 too. Said here: where it bites (e below about 0.2) this
    // packing limit is exceeded as well, and the packing's wording alone would hide that the collision is wrong.
    const double w0 = std::sqrt(kn_ / mstar_min), resolved = std::numbers::pi / 20 / w0;
    const double single = predicted_dashpot_limit(cn_ / (2 * std::sqrt(kn_ * mstar_min))) / w0;
    const std::string pair =
        dt_ > resolved ? fmt::format("; a binary collision of the lightest pair is off too: its spring's undamped frequency "
                                     "sqrt(k_n / m*) = {:.6g} (sqrt(pi^2 + ln^2 e) / t_c, which grows as e -> 0) is resolved as "
                                     "the t_c / 20 rule asks only below time.dt = pi / (20 w0) = {:.6g} (time.steps_per_contact "
                                     "{:.0f}); above it the realised restitution departs from the clamped law's{}",
                                     w0, resolved, std::ceil(tc / resolved),
                                     dt_ > single ? fmt::format(", and above {:.6g} (time.steps_per_contact {:.0f}) the collision "
                                                                "is unstable", single, std::ceil(tc / single))
                                                  : std::string())
                       : std::string();
    if (dt_ > limit)
      warn(fmt::format("time.dt = {:.6g} exceeds {:.6g}, the largest step at which grains of the lightest mass ({:.6g}) "
                       "pressed by {} damped contacts each (damping ratio {:.3g} on their fastest mode) settle: above it the "
                       "dashpots' velocity prediction makes them oscillate with growing amplitude, and dense packings heat "
                       "up instead of settling (time.steps_per_contact {:.0f} or more, without time.dt, would keep below it){}",
                       dt_, limit, lightest, int(z), worst_zeta, std::ceil(tc / limit), pair));
  }

  // The tangential spring and dashpot of a sticking contact (and the rolling ones) act on the half-step
  // velocity: x += h v, v += h (-k x - c v) / m is stable only for k h^2 / m + 2 c h / m <= 4, i.e. h below
  // 4 m / (c + sqrt(c^2 + 4 k m)). The time-step rule sees only the normal spring, and friction.stiffness_ratio
  // and damping_ratio (rolling.stiffness_ratio) are open-ended: an oblique collision of two unit spheres at
  // mu = 1e3 left with 1430 times its kinetic energy at k_t = 1e6 k_n, 1.9 times at c_t = 1e3 c_n, unwarned
  // (it grows from k_t = 330 k_n at 50 steps per contact, where this bound says 289). The mass of the tangential
  // mode is the pair's reduced mass with the grains' rotation: 1 / m_t = (1 + 1 / kappa) / m*, I = kappa m R^2
  // (kappa = 2/5 spheres, 1/2 disks); of the rolling mode the pair's reduced moment of inertia. The lightest
  // pair (the smallest moments) is the fastest: kn_ and cn_ are its. For rolling the bound is cautious: in a
  // 64-disk gas the spins grew from rolling.stiffness_ratio 45-100, where it says 32 (the smallest grains
  // need not touch each other).
  void warn_sticking_spring_step(const Scene& scene, double tc) {
    const auto stable_step = [](double k, double c, double m) { return 4 * m / (c + std::sqrt(c * c + 4 * k * m)); };
    const double kappa = D == 3 ? 0.4 : 0.5;
    const auto say = [&](const std::string& what, double limit, const std::string& mode) {
      if (dt_ > limit)
        warn(fmt::format("{}: time.dt = {:.6g} exceeds {:.6g}, the largest step at which {} are stable (the lightest pair; "
                         "the normal time-step rule does not see it): above it that motion grows every step and collisions "
                         "gain energy; lower the ratio or the step (time.steps_per_contact {:.0f} or more, without time.dt)",
                         what, dt_, limit, mode, std::ceil(tc / limit)));
    };
    const auto& P = sys_.particles;
    if (scene.boolean("contact.enabled") && scene.real("friction.coefficient") > 0) {
      // (+ 0: c_n is -0 at e = 1, -2 m* ln e / t_c)
      const double kt = scene.real("friction.stiffness_ratio") * kn_, ct = scene.real("friction.damping_ratio") * cn_ + 0.0;
      say(fmt::format("friction.stiffness_ratio = {:.6g} (k_t = {:.6g}) with friction.damping_ratio = {:.6g} (c_t = {:.6g})",
                      scene.real("friction.stiffness_ratio"), kt, scene.real("friction.damping_ratio"), ct),
          stable_step(kt, ct, smallest_reduced_mass() / (1 + 1 / kappa)), "a sticking contact's tangential spring and dashpot");
    }
    if (rolling_ && rolling_->stiffness > 0) {
      std::vector<std::pair<double, std::size_t>> inertia;   // the two smallest moments of inertia
      for (std::size_t i = 0; i < P.size(); ++i) inertia.emplace_back(kappa * P.mass[i] * P.radius[i] * P.radius[i], i);
      std::partial_sort(inertia.begin(), inertia.begin() + std::min<std::size_t>(2, inertia.size()), inertia.end());
      const auto [I1, i1] = inertia[0];
      const auto [I2, i2] = inertia.size() > 1 ? inertia[1] : inertia[0];
      const double cr = rolling_->damping * cn_ * P.radius[i1] * P.radius[i2];
      say(fmt::format("rolling.stiffness_ratio = {:.6g} (K_R = {:.6g}) with rolling.damping_ratio = {:.6g}",
                      scene.real("rolling.stiffness_ratio"), rolling_->stiffness, rolling_->damping),
          stable_step(rolling_->stiffness, cr, I1 * I2 / (I1 + I2)), "a sticking contact's rolling spring and dashpot");
    }
  }

  // Positions are doubles: far from the origin their spacing, |x| 2^-52, grows past the overlaps the contacts
  // work with, and below it nothing moves. Two grains 1e16 radii out kept their speeds but never moved (an
  // unchanged kinetic energy, no collision, nothing said); at 1e11 radii the collision's restitution was off by
  // 4e-4, at 1e8 by 1e-6. Warned where the spacing passes a thousandth of the clamp depth f_max R_min.
  void warn_coarse_coordinates(const Scene& scene, double rmin) {
    double far = 0;
    for (const auto& x : sys_.particles.position) far = std::max(far, x.cwiseAbs().maxCoeff());
    for (int a = 0; a < D; ++a)
      if (sys_.box.periodic[a])   // positions are wrapped into the box
        far = std::max({far, std::abs(sys_.box.lower[a]), std::abs(sys_.box.lower[a] + sys_.box.length[a])});
    const double spacing = std::nextafter(far, std::numeric_limits<double>::infinity()) - far;
    const double depth = scene.real("contact.overlap_limit") * rmin;
    const std::string layout = scene.text("particles.layout");
    const char* key = layout == "list" ? "particles.positions" : layout == "file" ? "particles.file" : "box.lower";
    if (spacing > 1e-3 * depth)
      warn(fmt::format("{}: coordinates reach {:.6g}, where doubles are {:.3g} apart, more than 1e-3 of the clamp depth "
                       "contact.overlap_limit R_min = {:.6g}: overlaps are resolved no finer than that, and moves below it "
                       "are lost to rounding (grains 1e16 radii out never moved); place the scene near the origin "
                       "(coordinates below {:.3g})", key, far, spacing, depth, depth * 1e-3 * std::pow(2.0, 52)));
  }

  // Two of the fastest initial grains approaching head-on close 2 v_max dt in a step. Beyond the clamp depth
  // f_max R_min their contact starts clamped, its onset unresolved, and a pair that closes more than its
  // diameters in a step is never seen overlapping at all: two grains at 1e4 crossed through each other with
  // their kinetic energy unchanged and nothing counted or warned. The time-step rule, from t_c alone, cannot
  // see the speeds; the initial ones are known here (later ones, gravity's among them, the energy check watches).
  void warn_unresolved_approach(const Scene& scene, double rmin) {
    double vmax = 0;
    for (const auto& v : sys_.particles.velocity) vmax = std::max(vmax, v.norm());
    const double depth = scene.real("contact.overlap_limit") * rmin, closing = 2 * vmax * dt_;
    const std::string mode = scene.text("particles.velocity");
    const char* source = mode == "list" ? "particles.velocities" : mode == "gaussian" ? "particles.kinetic_energy" : "particles.file";
    if (closing > depth)
      warn(fmt::format("{}: the fastest initial grain moves at {:.6g}, so two such "
                       "grains approaching head-on close 2 v_max dt = {:.6g} in a step of time.dt = {:.6g}, more than the "
                       "clamp depth contact.overlap_limit R_min = {:.6g}: their contacts start beyond the clamp and pairs "
                       "closing faster than their diameters per step pass through each other unseen; keep time.dt below "
                       "{:.6g} (more time.steps_per_contact) or the speeds lower",
                       source, vmax, closing, dt_, depth, depth / (2 * vmax)));
  }

  // Gravity time-step rule (physics.md section 3): the fastest orbit the softened potential allows is
  // the circular one of the two heaviest particles at their closest approach d:
  // T_orb = 2 pi sqrt((d^2 + eps^2)^(3/2) / (G (m_1 + m_2))). A step above T_orb / 20 resolves that orbit
  // with fewer than 20 steps.
  // The closest approach is the contact distance 2 R_min only where the contacts surely keep grains apart, and
  // a capped contact force need not: beyond delta_max = contact.overlap_limit R_min it stays k_n delta_max
  // (physics.md section 2), and a larger pull sinks the grains into each other down to the softened centre (at
  // k* = 10, two grains passed through each other and gained 18 times their kinetic energy, with no warning
  // while d was 2 R_min). Bound the pull on one grain by the whole system's mass at contact distance,
  // G m_max M / (2 R_min)^2: a capped force above it keeps d = 2 R_min, else d = 0 (then T_orb depends on eps
  // alone). The bound is generous, so d = 0 is the usual case: the default aggregation scene's capped force,
  // 647, is below its bound, 1000, and its step is 3.7 times below T_orb / 20 at d = 0.
  void warn_gravity_step(const Scene& scene, double rmin, bool contacts) {
    std::vector<double> m = sys_.particles.mass;
    if (m.size() < 2) return;
    double M = 0;
    for (double mi : m) M += mi;
    std::partial_sort(m.begin(), m.begin() + 2, m.end(), std::greater<>());
    const double G = scene.real("gravity.G"), eps = scene.real("gravity.softening") * rmin;
    // kn_: the lightest pair's stiffness, the smallest one (per-pair calibration stiffens heavier pairs)
    const double capped = contacts ? kn_ * scene.real("contact.overlap_limit") * rmin : 0.0;
    const double pull = G * m[0] * M / (4 * rmin * rmin);
    const bool held = contacts && capped > pull;
    const double d = held ? 2 * rmin : 0.0;
    const double orbit = 2 * std::acos(-1.0) * std::sqrt(std::pow(d * d + eps * eps, 1.5) / (G * (m[0] + m[1])));
    const std::string why =
        !contacts ? "no contacts"
        : held    ? fmt::format("contacts keep grains apart: their capped force k_n delta_max = {:.6g} exceeds "
                                "G m_max M / (2 R_min)^2 = {:.6g}", capped, pull)
                  : fmt::format("contacts cannot keep grains apart: their capped force k_n delta_max = {:.6g} is below "
                                "G m_max M / (2 R_min)^2 = {:.6g}, so grains may pass through each other", capped, pull);
    if (orbit > 0 && dt_ > orbit / 20)   // orbit = 0: unsoftened point masses, no bound to check against
      warn(fmt::format("time.dt = {:.6g} exceeds T_orb / 20 = {:.6g} (T_orb = {:.6g}: the circular orbit of the two heaviest "
                       "particles at their closest approach d = {:.6g} with softening eps = {:.6g}; {}): close gravitational "
                       "encounters are resolved by fewer than 20 steps", dt_, orbit / 20, orbit, d, eps, why));
  }

  // Energy check (physics.md section 3: nothing blows up silently). In a gravity scene with the aggregation's
  // contact law (or none) nothing adds energy: springs store it, dashpots, friction and drag take it. So
  // E = K + W + elastic (the contacts' stored energy: the clamped normal spring's potential, linear beyond the
  // cap, and the tangential spring's) may only fall or stay, within the integrator's error; a rise is energy
  // the integration makes, and a run that gains it ends hot (virial ratios above 1 from a cold dissipative
  // cloud). Checked where the outputs are computed (the runner's observable times, a host's reads), so it
  // costs nothing per step; warns once, when E exceeds its lowest value so far by more than energy_rise_limit
  // of the energy scale max(K, |W|, |E_0|), E_0 the first value checked.
  // The limit, 1 %, measured (the largest rise over a run, over the scale): the default aggregation scene
  // (1000 grains, 3 t_ff) 0 at its records, 8e-12 recorded every 10 steps; elastic runs (e = 1, overlaps to
  // 0.7 R) 1.4e-4; the collapse scene (no contacts) 3.6e-4; two grains passing through each other (k* = 10,
  // 30 steps per contact) 0.97, and the aggregation scene at k* = 10, zeta = 0.02, 2.7 (first above 1 % at
  // 0.34 t_ff). At k* = 100 the cloud's E rises 0.9-2.9 %: warned about, mildly, at most dampings.
  static constexpr double energy_rise_limit = 0.01;
  void check_energy(double kinetic) const {
    auto& o = observable_values_;
    auto& w = energy_watch_;
    const double W = o.at("gravity_potential_energy");
    const auto stored = o.find("elastic_energy");
    const double E = kinetic + W + (stored != o.end() ? stored->second : 0.0);
    if (w.warned || !std::isfinite(E)) return;
    if (!w.started) {
      w = {E, E, sys_.time, 1, 0};
      return;
    }
    if (E < w.minimum) {
      w.minimum = E, w.minimum_time = sys_.time;
      return;
    }
    const double scale = std::max({kinetic, std::abs(W), std::abs(w.first)}), rise = E - w.minimum;
    if (!(rise > energy_rise_limit * scale)) return;
    w.warned = 1;
    const std::string cause =
        kn_ > 0 ? fmt::format("contacts too soft for the gravitational load (k* = {:.3g}; largest overlap now {:.3g} R_min): "
                              "the capped contact force k_n delta_max cannot stop grains that gravity pulls together, they "
                              "pass through each other and the step misses the close encounter at the softening length; "
                              "raise k* (a shorter contact.duration) or contact.overlap_limit, or time.steps_per_contact",
                              o.at("normalised_stiffness"), o.count("max_overlap_ratio") ? o.at("max_overlap_ratio") : 0.0)
                : "a step too coarse for close encounters at the softening length: lower time.dt or raise gravity.softening";
    warn(fmt::format("energy check: at t = {:.6g} ({:.3g} t_ff, step {}) the total energy E = K + W + elastic = {:.6g} is "
                     "{:.6g} above its lowest value {:.6g} (at t = {:.6g}), {:.3g} % of the energy scale "
                     "max(K, |W|, |E_0|) = {:.6g} (the check's limit: {:g} %); nothing in this scene adds energy, so the "
                     "integration is making it and what follows (virial ratio, clusters) is an artefact. Likely cause: {}",
                     sys_.time, sys_.time / free_fall_time_, sys_.step, E, rise, w.minimum, w.minimum_time,
                     100 * rise / scale, scale, 100 * energy_rise_limit, cause));
  }

  // --- aggregation analysis (gravity scenes, physics.md section 8) ---
  void setup_aggregation_analysis(const Scene& scene, double rmin) {
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
    // contact-point attraction G m^2 / (2R)^2 of two such grains over a deformation R.
    double mean_radius = 0;
    for (std::size_t i = 0; i < P.size(); ++i) mean_radius += P.radius[i];
    mean_radius /= double(P.size());
    const double mean_mass = M / double(P.size());
    gravity_stiffness_ = scene.real("gravity.G") * mean_mass * mean_mass / (4 * std::pow(mean_radius, 3));
  }
  ClusterStats clusters() const {
    const auto& P = sys_.particles;
    return find_clusters<D>(P.position, P.radius, P.mass, cluster_tol_);
  }
  // Records the first time the largest cluster reaches the threshold (called every analysis.every steps).
  void track_aggregation() {
    if (!analysis_ || !std::isnan(aggregation_time_)) return;
    if (clusters().largest_fraction >= aggregation_threshold_) aggregation_time_ = sys_.time;
  }

  void check_finite_at_step(long step) const { check_finite(fmt::format("step {} (t = {:.9g})", step, sys_.time)); }
  void check_finite(const std::string& when) const {
    const auto& P = sys_.particles;
    for (std::size_t i = 0; i < P.size(); ++i) {
      const bool bad = !P.position[i].allFinite() || !P.velocity[i].allFinite() || !P.force[i].allFinite() ||
                       !P.angular_velocity[i].allFinite();
      if (!bad) continue;
      // Blame the step rules (or the energy check's finding) only when a check found them broken.
      const std::string hint =
          warnings_.empty()
              ? fmt::format("dt = {:.6g} passed the time-step checks at start-up, so look at the initial state "
                            "(coincident or deeply overlapping particles) and the scene's parameters", dt_)
              : fmt::format("the checks warned: {}", fmt::join(warnings_, "; "));
      throw SimulationError(fmt::format("non-finite value at {}: particle {} (mass {:.6g}) has position ({}), velocity "
                                        "({}), force ({}); {}",
                                        when, i, P.mass[i], fmt::join(P.position[i], ", "), fmt::join(P.velocity[i], ", "),
                                        fmt::join(P.force[i], ", "), hint));
    }
  }

  // --- variables ---
  void describe_variables(const Scene& scene) {
    auto param = [&](std::string name, double value, std::string unit, std::string doc) {
      vars_.push_back({std::move(name), std::move(unit), Causality::parameter, Variability::fixed, std::move(doc)});
      parameter_values_.push_back(value);
    };
    param("particles.count", double(sys_.particles.size()), "", "number of particles");
    vars_.back().is_integer = true;
    param("scene.dimension", D, "", "2 = disks, 3 = spheres");
    vars_.back().is_integer = true;
    param("time.dt", dt_, "s", "internal time step");
    if (network_) {
      param("adhesion.force", attraction_, "N", "F0: attraction of contacting grains");
      param("adhesion.range", scene.real("adhesion.range"), "m", "D0: range of the attraction beyond contact");
      param("adhesion.restitution", scene.real("adhesion.restitution"), "", "e_N, sets the normal damping as if F0 = 0");
      param("contact.k_n", kn_, "N/m", "normal stiffness K_N");
      param("contact.c_n", cn_, "kg/s", "normal damping of the lightest pair");
      param("friction.coefficient", scene.real("friction.coefficient"), "", "Coulomb coefficient mu");
      param("rolling.coefficient", scene.real("rolling.coefficient"), "m", "mu_R: rolling moment bound over K_N delta");
    } else if (scene.boolean("contact.enabled")) {
      param("contact.restitution", scene.real("contact.restitution"), "", "normal restitution e");
      param("contact.duration", scene.real("contact.duration"), "s", "contact duration t_c");
      param("contact.k_n", kn_, "N/m", "normal stiffness (global mode: from the smallest reduced mass)");
      param("contact.c_n", cn_, "kg/s", "normal damping (global mode)");
      param("friction.coefficient", scene.real("friction.coefficient"), "", "Coulomb coefficient mu");
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
      out("free_fall_time", "s", "t_ff = sqrt(R0^3 / (G M)), R0 = largest initial distance from the centre of mass");
      out("time_over_free_fall", "", "t / t_ff");
      out("fractal_dimension", "", "mass-radius D_f of the largest cluster (NaN when it is too small)");
      out("aggregation_time", "s", "first time f_max >= analysis.aggregation_threshold, checked every analysis.every steps; NaN until then");
      if (kn_ > 0)
        out("normalised_stiffness", "", "k* = k_n / k_g, k_g = G m^2 / (4 R^3) of the mean grain (m, R), k_n the calibration's "
                                        "(the lightest pair's in per-pair mode)");
    }
    if (network_) {
      describing_ = OutputGroup::network;
      out("coordination", "", "z = 2 (contacts + distant bonds) / N");
      out("coordination_compressive", "", "z+: the part of z carried by compressive forces");
      out("coordination_tensile", "", "z-: the part of z carried by tensile forces (distant bonds included)");
      out("coordination_zero", "", "z0: the part of z carrying no force (|F_N| <= analysis.zero_force * max(F0, mean |F_N|))");
      out("rattler_fraction", "", "x0: fraction of grains none of whose interactions carries a force");
      out("backbone_coordination", "", "z* = z / (1 - x0)");
      out("distant_bonds", "", "pairs attracting across a gap 0 <= h < D0");
      describing_ = OutputGroup::bonds;   // alone: a type-2 aggregation asks for it at every check
      out("bonded_clusters", "", "connected components of the contact + distant-bond graph (1: one aggregate holds every grain)");
      describing_ = OutputGroup::network;
      out("contacts_kept", "", "contacts (h < 0) present both now and at the last network.mark");
      out("contacts_lost", "", "contacts at the last network.mark that are open now");
      out("contacts_gained", "", "contacts now that were open at the last network.mark");
      // Each bin says its own range: every bin's text said "(the first bin also holds what is below)" until 2026-12-05.
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
  template <class Out>
  void describe_moduli_variables(Out& out) {
    out("B", "Pa", "bulk modulus of the contact network: sum_ab C_ab / D^2 (2D: (C11 + C12) / 2)");
    out("G", "Pa", "shear modulus for the cell's pure shears: (tr C - sum_ab C_ab / D) / (2 (D - 1)) (2D: (C11 - C12) / 2)");
    const char* digits = "123";
    for (int a = 0; a < D; ++a)
      for (int b = a; b < D; ++b)
        out(fmt::format("C{}{}", digits[a], digits[b]), "Pa",
            "stiffness d sigma_a / d eps_b over the cell's diagonal strains (the inverse of the compliance)");
    out("B_Voigt", "Pa", "Voigt bulk modulus: every grain follows the strain affinely without rotating (an upper bound of B)");
    out("G_Voigt", "Pa", "Voigt shear modulus (an upper bound of G)");
    out("B_Reuss", "Pa", "Reuss estimate: force increments proportional to the static forces, V P^2 / sum (F_N^2/K_N + F_T^2/K_T + Gamma^2/K_R)");
    out("Z2", "", "<F_N^2 + (K_N/K_T) F_T^2 + (K_N/K_R) Gamma^2> / <F_N>^2 over the interactions carrying force");
    out("moduli_mechanisms", "", "strain directions the contact network does not resist (B or G is then 0 within round-off)");
    out("moduli_unstable_modes", "", "negative stiffness directions (distant bonds' -F0/D0 not held): the moduli are then NaN");
    out("moduli_floppy_modes", "", "zero modes of the grains at fixed strain (rigid translations, rolling on one contact, ...)");
  }

  void refresh_moduli() const {
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

  template <class Out>
  void describe_cell_variables(Out& out) {
    const char* xyz = "xyz";
    for (int a = 0; a < D; ++a) out(fmt::format("cell_length_{}", xyz[a]), "m", "periodic cell length L");
    for (int a = 0; a < D; ++a) out(fmt::format("cell_strain_rate_{}", xyz[a]), "1/s", "(dL/dt) / L");
    for (int a = 0; a < D; ++a)
      for (int b = a; b < D; ++b)
        out(fmt::format("stress_{}{}", xyz[a], xyz[b]), "Pa", "stress tensor, contact + kinetic, compressive positive");
    out("pressure", "Pa", "trace(stress) / D, contact + kinetic");
    out("pressure_kinetic", "Pa", "kinetic part of the pressure (velocities relative to the affine flow)");
    out("pressure_reduced", "", "P* of the current stress: a P / F0 (2D), a^2 P / F0 (3D)");
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
    add_control({"cell.pressure", "", Causality::input, Variability::continuous,
                 "target reduced pressure P* (a P / F0 in 2D, a^2 P / F0 in 3D)", 0, 1e6},
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
    VariableInfo active{"cell.active", "", Causality::input, Variability::discrete,
                        "1: the barostat moves the cell; 0: the cell is held fixed at rest (e.g. while a type-2 sample "
                        "aggregates)", 0, 1};
    active.is_integer = true;
    add_control(active, [this] { return cell_active_ ? 1.0 : 0.0; },
                [this](double v) {
                  if (v != 0 && v != 1) throw SimulationError(fmt::format("cell.active = {} is not allowed: 0 or 1", v));
                  if ((v == 1) == cell_active_) return;   // unchanged (a restored state sets every control)
                  cell_active_ = v == 1;
                  if (cell_active_) barostat_->release();
                  else barostat_->hold();
                });
  }

  // The four criteria as ratios to their tolerances (each below 1 passes).
  EquilibriumMeasures equilibrium_ratios() const {
    auto m = measure_equilibrium<D>(sys_.particles, stress(), barostat_->target_pressure(), force_unit_, length_unit_);
    m.force /= tolerances_.force, m.torque /= tolerances_.torque, m.stress /= tolerances_.stress,
        m.kinetic /= tolerances_.kinetic;
    return m;
  }

  void refresh_cell_observables() const {
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

  // Computes the outputs of one group, unless they are already those of this step: a programme's checks
  // read a few outputs every hundred steps, and the others (the contact network's analysis, the energies)
  // are computed only when asked for.
  void refresh(OutputGroup group) const {
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

  void refresh_general() const {
    const auto& P = sys_.particles;
    auto& o = observable_values_;
    double kt = 0, kr = 0;
    Vec<D> p = Vec<D>::Zero();
    Eigen::Vector3d L = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < P.size(); ++i) {
      // About the origin from the positions as written (wrapped into the cell), so that the file's
      // positions reproduce it; the engine's own may sit one cell outside between wraps.
      const Vec<D> x = sys_.box.wrap(P.position[i]);
      kt += 0.5 * P.mass[i] * P.velocity[i].squaredNorm();
      kr += 0.5 * P.inertia[i] * P.angular_velocity[i].squaredNorm();
      p += P.mass[i] * P.velocity[i];
      if constexpr (D == 3) {
        L += P.mass[i] * x.cross(P.velocity[i]) + P.inertia[i] * P.angular_velocity[i];
      } else {
        L[2] += P.mass[i] * (x[0] * P.velocity[i][1] - x[1] * P.velocity[i][0]) +
                P.inertia[i] * P.angular_velocity[i][0];
      }
    }
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
      if (kn_ > 0) o["normalised_stiffness"] = kn_ / gravity_stiffness_;
    }
    if (energy_check_) check_energy(kt + kr);
    if (collisions_) {
      const double n = double(collisions_->collisions()), a = double(collisions_->adhesive());
      o["collision_count"] = n;
      o["adhesive_collision_count"] = a;
      o["adhesive_collision_fraction"] = n > 0 ? a / n : std::numeric_limits<double>::quiet_NaN();
      o["open_collision_count"] = double(collisions_->open());
    }
  }

  void refresh_bonds() const {
    observable_values_["bonded_clusters"] = double(count_bonded_clusters(sys_.particles.size(), interactions()));
  }

  void refresh_network() const {
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
  }

  System<D> sys_;
  std::vector<std::unique_ptr<ForceModule<D>>> modules_;
  SoftenedGravity<D>* gravity_ = nullptr;   // in modules_, when the scene has self-gravity
  RollingResistance* rolling_ = nullptr;     // the contact module's rolling parameters, when it has them
  bool uses_list_ = false, rotate_ = false;
  bool orient_ = true;   // particles.track_orientation
  double dt_ = 0, kn_ = 0, cn_ = 0;
  // The clock (time_after): the time of the last step that was not a whole dt (or of the start), and the
  // whole steps since.
  double clock_origin_ = 0;
  long clock_steps_ = 0;
  // A pair's k and c are kn_ (m* / m*_min)^first and cn_ (m* / m*_min)^second (global calibration: 0, 0).
  std::pair<double, double> pair_law_scaling_{0.0, 0.0};
  bool analysis_ = false;   // gravity scenes only
  double cluster_tol_ = 0, aggregation_threshold_ = 0.9, free_fall_time_ = 0, gravity_stiffness_ = 0;
  long analysis_every_ = 100;
  bool network_ = false;   // adhesion scenes: contact-network outputs
  double attraction_ = 0, zero_force_ = 1e-5, network_mark_ = 0;
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
  double cell_list_reach_ = 0;
  EquilibriumTolerances tolerances_;
  bool cell_active_ = true;
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

}  // namespace

std::unique_ptr<Simulation> Simulation::create(const Scene& scene) {
  scene.validate();
  if (scene.integer("scene.dimension") == 2) return std::make_unique<SimulationImpl<2>>(scene);
  return std::make_unique<SimulationImpl<3>>(scene);
}

}  // namespace grains
