#include "protocols/consolidation_programme.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

#include <fmt/format.h>

#include "cell/force_unit.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"

namespace grains {

ProgrammeSettings ProgrammeSettings::from_scene(const Scene& scene) {
  ProgrammeSettings p;
  p.preparation = scene.text("programme.preparation");
  p.start_pressure = scene.real("cell.pressure");
  p.top_pressure = scene.real("programme.top_pressure");
  p.stages_per_decade = int(scene.integer("programme.stages_per_decade"));
  p.unload_stages_per_decade = int(scene.integer("programme.unload_stages_per_decade"));
  p.load = scene.boolean("programme.load");
  p.unload = scene.boolean("programme.unload");
  p.check_every = scene.integer("programme.check_every");
  p.stage_budget = scene.integer("programme.stage_budget");
  p.aggregation_budget = scene.integer("programme.aggregation_budget");
  p.first_compression_time = scene.real("programme.first_compression_time");
  // The rolling dashpot belongs to the consolidation law; the drag serves any law.
  p.quench.damping = scene.boolean("adhesion.enabled") ? scene.real("programme.quench_damping") : 0.0;
  p.quench.drag = scene.real("programme.quench_drag");
  p.quench.background = scene.real("programme.background_drag");
  p.quench.drag_min = scene.real("programme.quench_drag_min");
  p.quench.patience = scene.integer("programme.quench_patience");
  p.quench.settle_ratio = scene.real("programme.settle_ratio");
  p.quench.settle_checks = scene.integer("programme.settle_checks");
  p.quench.settle_compaction = scene.real("programme.settle_compaction");
  p.quench.confirm_checks = scene.integer("programme.confirm_checks");
  if (!scene.boolean("cell.enabled"))
    scene.fail("cell.enabled", "the consolidation programme drives a pressure-controlled cell: set cell.enabled = true");
  if (scene.has("cell.pressure_final"))
    scene.fail("cell.pressure_final", fmt::format("value {} ramps the pressure, which the programme sets stage by stage: "
                                                  "drop it (a ramp is for `grains run` and hosts)",
                                                  scene.real("cell.pressure_final")));
  // The loading ladder multiplies the start pressure: from 0 it never rises, and stages would be planned until memory
  // ran out.
  if (p.load && !(p.start_pressure > 0))
    scene.fail("cell.pressure", fmt::format("value {} starts the loading stages (P* times 10^(k / "
                                            "programme.stages_per_decade)), which never rise from 0: allowed a value > 0 "
                                            "with programme.load = true (or programme.load = false)", p.start_pressure));
  if (p.load && p.top_pressure < p.start_pressure)
    scene.fail("programme.top_pressure", fmt::format("value {} is below the start pressure cell.pressure = {}: allowed "
                                                     ">= cell.pressure", p.top_pressure, p.start_pressure));
  // A damper the scene keeps on throughout cannot also be the quench the programme switches.
  const auto refuse_both = [&](const char* key, const char* what, const char* quench_key, double quench) {
    if (quench > 0 && scene.real(key) > 0)
      scene.fail(key, fmt::format("value {} keeps the {} on throughout, but {} = {} sets it in the programme's "
                                  "stages: set one of them to 0", scene.real(key), what, quench_key, quench));
  };
  refuse_both("rolling.damping_ratio", "rolling dashpot", "programme.quench_damping", p.quench.damping);
  refuse_both("drag.rate", "drag", "programme.quench_drag", p.quench.drag);
  refuse_both("drag.rate", "drag", "programme.background_drag", p.quench.background);
  if (p.first_compression_time > 0 && p.preparation == "none")
    scene.fail("programme.first_compression_time", fmt::format("value {} ramps the first compression of a type 1 or type 2 "
                                                               "preparation, and programme.preparation is \"none\": set it "
                                                               "to 0", p.first_compression_time));
  // The ramp starts at P* = 0, which a cohesionless cell refuses (its force scale comes from the pressure).
  const double force_unit = cell_force_unit(scene);
  if (p.first_compression_time > 0 && force_unit == 0)
    scene.fail("programme.first_compression_time",
               fmt::format("value {} ramps the first compression's target from P* = 0, which a cohesionless cell "
                           "(cell.force_unit = 0) does not allow: set it to 0", p.first_compression_time));
  if (p.preparation == "type2" && !scene.boolean("adhesion.enabled"))
    scene.fail("programme.preparation", "type2 aggregates the grains ballistically: it needs adhesion.enabled = true");
  if (p.preparation == "type2" && force_unit == 0)   // its relaxation at P* = 0 needs a force scale other than P
    scene.fail(scene.has("cell.force_unit") ? "cell.force_unit" : "adhesion.force",
               "value 0 leaves type2's relaxation at P* = 0 without a force scale (cohesionless cells need P* > 0): "
               "allowed a value > 0");
  return p;
}

// A floor above the start would be no step-down at all; said, not clamped silently (the default floor stays quiet
// under a smaller quench_drag: the drag then keeps that value). Only for the scene a user gives: a resumed
// programme's stored scene spells out the default, which the check would refuse.
void ProgrammeSettings::refuse_floor_above_drag(const Scene& scene) {
  const double drag = scene.real("programme.quench_drag"), floor = scene.real("programme.quench_drag_min");
  if (scene.has("programme.quench_drag_min") && drag > 0 && scene.integer("programme.quench_patience") > 0 && floor > drag)
    scene.fail("programme.quench_drag_min",
               fmt::format("value {} is above programme.quench_drag = {}, from which the drag steps down: allowed "
                           "<= programme.quench_drag (or programme.quench_patience = 0 to keep the drag)", floor, drag));
}

void ProgrammeSettings::check_time_step(const Scene& scene, double dt) const {
  const double steps = first_compression_time / dt;
  if (!(steps <= Simulation::max_steps))   // the ramp's step count (and the stage's budget after it) must fit
    scene.fail("programme.first_compression_time",
               fmt::format("value {} is {:.3g} steps of dt = {:.6g}; at most {:.0e} steps: a shorter ramp",
                           first_compression_time, steps, dt, Simulation::max_steps));
}

std::vector<std::pair<std::string, double>> programme_pressures(const ProgrammeSettings& p) {
  std::vector<std::pair<std::string, double>> out;
  const double slack = 1 + 1e-3;   // 0.01 * 10^(25/8) = 13.335 counts as the paper's 13.33
  if (p.load)
    for (int k = 1;; ++k) {
      const double P = p.start_pressure * std::pow(10.0, double(k) / p.stages_per_decade);
      if (P > p.top_pressure * slack) break;
      out.emplace_back("loading", P);
    }
  if (p.unload && !out.empty()) {
    const double top = out.back().second;
    for (int k = 1;; ++k) {
      const double P = top / std::pow(10.0, double(k) / p.unload_stages_per_decade);
      if (P <= p.start_pressure * slack) break;
      out.emplace_back("unloading", P);
    }
    out.emplace_back("unloading", p.start_pressure);
  }
  return out;
}

std::vector<std::pair<std::string, double>> programme_stages(const ProgrammeSettings& p) {
  std::vector<std::pair<std::string, double>> out;
  if (p.preparation == "type2")   // ballistic aggregation in a fixed cell, then relaxation at P* = 0
    out.emplace_back("aggregation", std::numeric_limits<double>::quiet_NaN()), out.emplace_back("equilibrate", 0.0);
  out.emplace_back("equilibrate", p.start_pressure);
  for (const auto& stage : programme_pressures(p)) out.push_back(stage);
  return out;
}

namespace {

// The prepared state's stage at the start pressure: the one a first compression time ramps.
bool first_compression(const std::string& phase, double P, const ProgrammeSettings& p) {
  return phase == "equilibrate" && P > 0 && P == p.start_pressure && p.preparation != "none";
}

// The steps of the ramp that begins the first compression (its budget counts from the ramp's end): the
// ramp's time in whole chunks of check_every. The caller has checked that the time fits max_steps.
long ramp_steps(double first_compression_time, double dt, const ProgrammeSettings& p) {
  return first_compression_time > 0 ? long(std::ceil(first_compression_time / dt / double(p.check_every))) * p.check_every : 0;
}

// What a stage row records: whichever of these the scene has (the elastic moduli with
// analysis.elastic_moduli), and the normal-force histogram.
const char* const recorded[] = {
    "pressure_reduced", "solid_fraction", "coordination", "coordination_compressive", "coordination_tensile",
    "coordination_zero", "rattler_fraction", "backbone_coordination", "distant_bonds", "bonded_clusters",
    "contacts_kept", "contacts_lost", "contacts_gained", "contacts_at_friction_bound", "contacts_at_rolling_bound",
    "contacts", "cell_length_x", "cell_length_y", "cell_length_z",
    "equilibrium_force", "equilibrium_torque", "equilibrium_stress", "equilibrium_kinetic", "kinetic_energy",
    "B", "G", "C11", "C22", "C33", "C12", "C13", "C23", "B_Voigt", "G_Voigt", "B_Reuss", "Z2", "moduli_mechanisms",
    "moduli_unstable_modes", "moduli_floppy_modes"};

class Runner {
 public:
  Runner(Simulation& s, const ProgrammeSettings& p, const std::function<void(const StageRecord&)>& on_stage,
         const StageCheck& on_check, const StageProgress& from, const StopPoll& poll)
      : s_(s), p_(p), on_stage_(on_stage), on_check_(on_check), poll_(poll), network_(s.has("network.mark")),
        names_(stage_record_names(s)), from_(from) {}

  std::vector<StageRecord> run() {
    const auto stages = programme_stages(p_);
    for (std::size_t k = std::size_t(from_.stage); k < stages.size() && !stopped_; ++k) {
      const auto& [phase, P] = stages[k];
      if (phase == "aggregation") {   // in a fixed cell
        s_.set("cell.active", 0);
        stage(phase, P, p_.aggregation_budget, [&](StageRecord&) { return s_.get("bonded_clusters") == 1.0; });
      } else {   // the first stage under pressure: the prepared state at the start pressure
        equilibrate(phase, P, first_compression(phase, P, p_));
      }
    }
    return std::move(records_);
  }

 private:
  // Run until `done` holds (checked every check_every steps) or the budget is spent; `quench` gives the
  // stage's quench progress for on_check. The first stage run may continue one begun before (from_).
  // A stage with ramp_steps > 0 first raises its target from 0 in chunks of check_every (target * steps /
  // ramp_steps over each), not judged until the ramp ends; its budget counts from there.
  template <class Done, class Quench>
  void stage(const std::string& phase, double target, long budget, Done done, Quench quench, long ramp_steps = 0) {
    StageRecord r;
    r.index = from_.stage + int(records_.size());
    r.phase = phase;
    r.target = target;
    if (records_.empty()) r.steps = from_.steps;
    budget += ramp_steps;
    while (r.steps < budget) {
      const bool ramping = r.steps < ramp_steps;
      // A stage continued from between two checks (StopPoll) goes on to the next one, its target already set.
      const long to_check = p_.check_every - r.steps % p_.check_every;
      if (to_check == p_.check_every) {
        if (ramping) s_.set("cell.pressure", target * double(r.steps) / double(ramp_steps));
        else if (ramp_steps > 0 && r.steps == ramp_steps) s_.set("cell.pressure", target);
      }
      const long n = ramping ? to_check : std::min(to_check, budget - r.steps);
      if (step_or_stop(r, n, budget, quench)) return;
      if (!ramping && done(r)) {
        r.reached = true;
        break;
      }
      if (r.steps < budget && on_check_ && on_check_(r, budget, StageProgress{r.index, r.steps, quench()})) {
        stopped_ = true;
        return;
      }
    }
    r.time = s_.time();
    for (const auto& name : names_) r.values.emplace_back(name, s_.get(name));
    // Contacts kept / lost / gained are counted from the previous stage's end: it becomes the reference.
    if (network_) s_.set("network.mark", double(r.index + 1));
    if (on_stage_) on_stage_(r);
    records_.push_back(std::move(r));
  }
  // Takes n steps, asking poll_ between pieces of them; true: stopped there, on_check_ having said so.
  template <class Quench>
  bool step_or_stop(StageRecord& r, long n, long budget, Quench& quench) {
    while (n > 0) {
      const long piece = poll_.every > 0 ? std::min(n, poll_.every) : n;
      s_.step_n(piece);
      r.steps += piece, n -= piece;
      if (n > 0 && poll_.requested && poll_.requested() && on_check_ &&
          on_check_(r, budget, StageProgress{r.index, r.steps, quench()})) {
        stopped_ = true;
        return true;
      }
    }
    return false;
  }

  template <class Done>
  void stage(const std::string& phase, double target, long budget, Done done) {
    stage(phase, target, budget, done, [] { return std::vector<double>{}; });
  }

  void equilibrate(const std::string& phase, double target, bool first_compression) {
    if (s_.get("cell.active") != 1) s_.set("cell.active", 1);   // released after the aggregation
    const double T = first_compression ? p_.first_compression_time : 0.0;
    if (!(T / s_.dt() <= Simulation::max_steps))   // ProgrammeSettings::check_time_step names the key
      throw std::invalid_argument(fmt::format("programme.first_compression_time = {} is more than 1e15 steps", T));
    const long ramp = ramp_steps(T, s_.dt(), p_);
    const long at = records_.empty() ? from_.steps : 0;   // a resumed stage goes on where it stood
    // The quench sets its drags in units of the inertial time at the stage's target (above P* = 1 it depends
    // on it), also in a ramp and at a resume inside one: the ramp's own target comes after.
    s_.set("cell.pressure", target);
    QuenchSettings q = p_.quench;
    if (target == 0) q.background = 0;   // the relaxation after the aggregation runs on the paper's law
    StageQuench quench(s_, q);
    if (records_.empty() && from_.steps > 0) quench.resume(from_.quench);
    // Continued between two checks of the ramp: its target is the one set at the last check.
    if (at < ramp) s_.set("cell.pressure", target * double(at - at % p_.check_every) / double(ramp));
    stage(phase, target, p_.stage_budget, [&](StageRecord& r) {
      const bool reached = quench.in_equilibrium(r.steps);
      r.quench_start = quench.start();
      r.quench_drag = quench.drag();
      return reached;
    }, [&] { return quench.progress(); }, ramp);
    if (!stopped_) quench.end();   // stopped: the simulation stays as its checkpoint has it
  }

  Simulation& s_;
  const ProgrammeSettings& p_;
  const std::function<void(const StageRecord&)>& on_stage_;
  const StageCheck& on_check_;
  const StopPoll& poll_;
  bool network_;
  std::vector<std::string> names_;
  StageProgress from_;
  bool stopped_ = false;
  std::vector<StageRecord> records_;
};

}  // namespace

std::vector<double> StageProgress::values() const {
  std::vector<double> v{double(stage), double(steps)};
  v.insert(v.end(), quench.begin(), quench.end());
  return v;
}

StageProgress StageProgress::from_values(const std::vector<double>& v, const ProgrammeSettings& p, double dt) {
  const auto stages = programme_stages(p);
  if (v.size() < 2 || v[0] < 0 || v[0] >= double(stages.size()) || v[0] != std::floor(v[0]))
    throw std::invalid_argument(fmt::format("the stage under way is not one of the programme's {} stages", stages.size()));
  StageProgress s{int(v[0]), long(v[1]), std::vector<double>(v.begin() + 2, v.end())};
  const auto& [phase, P] = stages[std::size_t(s.stage)];
  const bool aggregation = phase == "aggregation";
  const bool ramped = first_compression(phase, P, p) && p.first_compression_time / dt <= double(Simulation::max_steps);
  const long ramp = ramped ? ramp_steps(p.first_compression_time, dt, p) : 0;   // the budget counts from its end
  const long budget = aggregation ? p.aggregation_budget : p.stage_budget;
  if (s.steps < 0 || s.steps >= budget + ramp)
    throw std::invalid_argument(fmt::format("stage {} is {} steps in, outside its budget of {}{}", s.stage, s.steps, budget,
                                            ramp > 0 ? fmt::format(" after a ramp of {} steps", ramp) : ""));
  if (s.quench.size() != (aggregation || s.steps == 0 ? 0u : 9u))
    throw std::invalid_argument(fmt::format("stage {}'s quench has {} numbers", s.stage, s.quench.size()));
  return s;
}

std::vector<std::string> stage_record_names(const Simulation& s) {
  std::vector<std::string> names;
  for (const char* name : recorded)
    if (s.has(name)) names.emplace_back(name);
  for (const auto& v : s.variables())
    if (v.name.rfind("force_histogram_", 0) == 0) names.push_back(v.name);
  return names;
}

std::vector<StageRecord> run_programme(Simulation& s, const ProgrammeSettings& p,
                                       const std::function<void(const StageRecord&)>& on_stage,
                                       const StageCheck& on_check, const StageProgress& from,
                                       const StopPoll& poll) {
  return Runner(s, p, on_stage, on_check, from, poll).run();
}

}  // namespace grains
