#include "instance.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <new>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/byte_stream.hpp"
#include "io/file_name.hpp"

namespace grains::fmu {
namespace {

const char* phase_name(Phase p) {
  switch (p) {
    case Phase::instantiated: return "the instantiated state (before initialization)";
    case Phase::configuration: return "configuration mode";
    case Phase::initialization: return "initialization mode";
    case Phase::stepping: return "step mode (after initialization)";
    case Phase::terminated: return "the terminated state";
    default: return "the error state (after a failed step; only get, reset, free and setting a state saved before are allowed)";
  }
}
const char* type_name(ValueType t) {
  return t == ValueType::real ? "Real/Float64" : t == ValueType::integer ? "Integer/Int64" : "Boolean";
}
const char* role_name(Role r) {
  switch (r) {
    case Role::calculated_parameter: return "a calculated parameter (derived by the engine)";
    case Role::independent: return "the independent variable (time)";
    case Role::output: return "an output";
    case Role::particle_array: return "an output array";
    default: return "a parameter";
  }
}

// The value as TOML text of the scene key's kind, so the scene checks it like any --set (an enumeration's value
// within its items).
std::string toml_value(const FmuVariable& v, double value) {
  if (!v.items.empty()) return fmt::format("\"{}\"", v.items[static_cast<std::size_t>(value) - 1]);
  if (v.type == ValueType::boolean) return value != 0 ? "true" : "false";
  if (v.type == ValueType::integer) return fmt::format("{}", static_cast<long long>(value));
  std::string s = fmt::format("{}", value);   // nan, inf, -inf are TOML floats as they are
  if (std::isfinite(value) && s.find_first_of(".eE") == std::string::npos) s += ".0";
  return s;
}

// A fixed parameter's value as a message gives it: an enumeration's with its item ("2 (tree)").
std::string shown_value(const FmuVariable& v, double value) {
  const std::size_t k = static_cast<std::size_t>(value);
  if (!v.items.empty() && value >= 1 && k <= v.items.size()) return fmt::format("{} ({})", k, v.items[k - 1]);
  return fmt::format("{}", value);
}

// A fixed parameter's value in a scene (its type's reading of the scene key).
double scene_value(const Scene& scene, const FmuVariable& v) {
  if (!v.items.empty()) return item_value(v, scene.text(v.scene_key));
  return v.type == ValueType::real      ? scene.real(v.scene_key)
         : v.type == ValueType::integer ? double(scene.integer(v.scene_key))
                                        : double(scene.boolean(v.scene_key));
}

// A state: this word, the parameters' fingerprint, the start and host times, the token's hash and the fixed
// parameters' values (to name those that differ), the engine's bytes, then a check sum over all of them (the
// engine's own sum leaves the header out, and a damaged host time would make the next step run the gap).
constexpr std::uint64_t state_magic = 0x34534d4649524721ull;           // "!GRIFMS4"
constexpr std::uint64_t state_magic_unnamed = 0x33534d4649524721ull;   // "!GRIFMS3": before the parameters' values
constexpr std::uint64_t state_magic_unsummed = 0x32534d4649524721ull;  // "!GRIFMS2": before the check sum
constexpr std::size_t state_header = 4 * 8, state_sum = 8;

// Why `bytes` are not an intact state of this build's format, or "" when they are.
std::string state_defect(std::span<const std::byte> bytes) {
  std::uint64_t magic = 0;
  if (bytes.size() >= 8) std::memcpy(&magic, bytes.data(), 8);
  if (magic == state_magic_unsummed || magic == state_magic_unnamed) return "the state was saved by an older build of this FMU, whose format this one does not read";
  if (bytes.size() >= 8 && magic != state_magic) return "these bytes are not a state of a grains FMU";
  if (bytes.size() < state_header + state_sum) return "the state is empty or truncated";
  std::uint64_t sum;
  std::memcpy(&sum, bytes.data() + bytes.size() - state_sum, state_sum);
  if (sum != check_sum(bytes.first(bytes.size() - state_sum)))
    return "the state is corrupted or truncated (its check sum, over the start and current time too, does not match its bytes)";
  return {};
}

std::uint64_t fnv1a(std::string_view text, std::uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

}  // namespace

std::unique_ptr<Instance> Instance::create(const char* function, std::string name, std::string_view token,
                                           const std::filesystem::path& resources, Logger logger, bool logging_on) {
  const bool fmi3 = std::string_view(function).starts_with("fmi3");
  std::unique_ptr<Instance> in(new Instance(std::move(name), std::move(logger), logging_on, fmi3));
  in->answering(function);
  const auto file = resources / "scene.toml";
  try {
    if (!std::filesystem::is_regular_file(file))
      throw SceneError(fmt::format("the FMU's scene '{}' does not exist: the resource location passed by the host must be "
                                   "the FMU's extracted resources/ directory", file.string()));
    in->packaged_ = Scene::from_file(file, {}, "the FMU's parameters");   // not the host's temporary folder
    in->scene_ = in->packaged_;
    in->sim_ = Simulation::create(in->scene_);
    in->table_ = describe_model(in->scene_, *in->sim_);
  } catch (const std::bad_alloc&) {
    in->error(fmt::format("instantiation failed: {}", out_of_memory_message));
    return nullptr;
  } catch (const std::exception& e) {
    in->error(fmt::format("instantiation failed: {}", e.what()));
    return nullptr;
  }
  in->dirty_ = false;
  const std::string expected = instantiation_token(in->table_);
  if (token.empty()) {   // FMI 2 and 3: the host passes the model description's guid / instantiationToken
    in->error(fmt::format("no instantiation token given: pass the modelDescription.xml's ('{}')", expected));
    return nullptr;
  }
  if (token != expected) {
    in->error(fmt::format("instantiation token '{}' does not match this binary and scene ('{}'): the modelDescription.xml "
                          "and the resources come from different builds", token, expected));
    return nullptr;
  }
  in->log_new_warnings();   // the start-up warnings
  in->take_warned();         // instantiation returns no status to carry them
  in->answering(nullptr);
  return in;
}

bool Instance::enabled(const char* category) const {
  if (std::strcmp(category, log_error) == 0) return true;   // errors always reach the host
  // Warnings too (the call returns Warning, which says the FMU logged one), unless the host switched them off by name.
  if (std::strcmp(category, log_warning) == 0) {
    const auto it = categories_.find(category);
    return it == categories_.end() || it->second;
  }
  if (!logging_on_) return false;
  if (categories_.empty()) return true;
  auto it = categories_.find(category);
  return it != categories_.end() && it->second;
}

Status Instance::set_debug_logging(bool on, std::span<const char* const> categories) {
  // Every category is checked before any is applied: a refused call leaves the logging as it was.
  for (const char* c : categories) {
    if (!c) return error("a log category is a null pointer: each entry of categories must name a category");
    bool known = false;
    for (const auto& [name, doc] : log_categories()) known |= std::strcmp(c, name) == 0;
    if (!known) {
      std::string list;
      for (const auto& [name, doc] : log_categories()) list += fmt::format("{}{}", list.empty() ? "" : ", ", name);
      return error(fmt::format("unknown log category '{}': this FMU declares {}", c, list));
    }
  }
  logging_on_ = on;
  categories_.clear();
  for (const char* c : categories) categories_[c] = on;
  return Status::ok;
}

Status Instance::error(const std::string& message) {
  if (answering_ && !std::string_view(message).starts_with(answering_))
    logger_(Status::error, log_error, fmt::format("{}: {}", answering_, message));
  else
    logger_(Status::error, log_error, message);
  return Status::error;
}

void Instance::warn(const std::string& message) {
  if (enabled(log_warning))
    logger_(Status::warning, log_warning, answering_ ? fmt::format("{}: {}", answering_, message) : message);
  warned_ = true;
}

Status Instance::unsupported(const char* function, const char* why) {
  return error(fmt::format("{} is not supported by this FMU: {}", function, why));
}

void Instance::log_call(const std::string& call) {
  if (enabled(log_calls)) logger_(Status::ok, log_calls, call);
}

Status Instance::check_phase(const char* function, std::initializer_list<Phase> allowed) {
  for (Phase p : allowed)
    if (p == phase_) return Status::ok;
  // The host's own call in its version's spelling where one is being answered ("Terminate" is both versions')
  return error(fmt::format("{} is not allowed in {}", answering_ ? answering_ : function, phase_name(phase_)));
}

Status Instance::ensure_built() {
  if (sim_ && !dirty_) return Status::ok;
  try {
    auto sim = Simulation::create(scene_);
    const ModelTable now = describe_model(scene_, *sim);
    if (!same_structure(now, table_)) {
      return error(fmt::format("the parameter values set ({}) change the FMU's set of variables (the simulation would be {}): "
                               "only values that keep the packaged scene's variables are allowed",
                               fmt::join(moved_parameters(), ", "), structure_change(now, table_)));
    }
    for (const auto& [index, value] : pending_controls_) sim->set(index, value);
    // A rebuild (a parameter set again, in Initialization Mode too, as libcosim does) logs only the start-up
    // warnings the host has not had from the simulation before (else each is said twice).
    std::vector<std::string> said;
    if (sim_) said.assign(sim_->warnings().begin(), sim_->warnings().begin() + warnings_logged_);
    sim_ = std::move(sim);
    dirty_ = false;   // before the logger runs: a read it makes from inside finds the simulation built
    warnings_logged_ = 0;
    log_new_warnings(said);
    log_new_meanings(now);
  } catch (const std::bad_alloc&) {
    return error(out_of_memory_message);
  } catch (const std::exception& e) {
    return error(fmt::format("cannot build the simulation from the parameters: {}", e.what()));
  }
  return Status::ok;
}

Status Instance::enter_configuration() {
  if (Status s = check_phase("EnterConfigurationMode", {Phase::instantiated}); s != Status::ok) return s;
  phase_ = Phase::configuration;
  return Status::ok;
}
Status Instance::exit_configuration() {
  if (Status s = check_phase("ExitConfigurationMode", {Phase::configuration}); s != Status::ok) return s;
  phase_ = Phase::instantiated;
  return Status::ok;
}

Status Instance::check_experiment(const char* function, const Experiment& experiment) {
  const double start = experiment.start;
  if (!std::isfinite(start)) return error(fmt::format("{}: start time {} is not allowed: a finite number", function, start));
  if (experiment.stop && !(std::isfinite(*experiment.stop) && *experiment.stop >= start))
    return error(fmt::format("{}: stop time {} is not allowed with start time {}: a finite number at or after the start "
                             "time (or no stop time: stopTimeDefined = false)", function, *experiment.stop, start));
  return Status::ok;
}

Status Instance::enter_initialization(const char* function, const Experiment& experiment) {
  if (Status s = check_phase(function, {Phase::instantiated}); s != Status::ok) return s;
  if (Status s = check_experiment(function, experiment); s != Status::ok) return s;
  if (Status s = ensure_built(); s != Status::ok) return s;
  start_time_ = host_time_ = experiment.start;
  stop_time_ = experiment.stop;
  phase_ = Phase::initialization;
  return Status::ok;
}

Status Instance::exit_initialization() {
  if (Status s = check_phase("ExitInitializationMode", {Phase::initialization}); s != Status::ok) return s;
  if (Status s = ensure_built(); s != Status::ok) return s;
  if (snapshots_every_ > 0) {
    // The instance name is the host's string; it must not lead the file out of the working directory. A name that
    // is no plain file name (a host's path to the FMU) is made one, and the host told where the snapshots go.
    const std::string file = plain_file_name_from(name_) + ".h5";
    if (!is_plain_file_name(name_))
      warn(fmt::format("fmu.snapshots_every: the snapshots go to <instance name>.h5 in the working directory, and "
                       "instance name \"{}\" is not a plain file name ({}): they go to \"{}\"", name_,
                       plain_file_name_rule, file));
    try {
      snapshots_ = std::make_unique<SnapshotOutput>(file, *sim_, GRAINS_VERSION, scene_.resolved_toml());
    } catch (const std::exception& e) {
      return error(e.what());
    }
    next_snapshot_ = sim_->step_count();
    if (Status s = write_snapshot_if_due(); s != Status::ok) return s;
  }
  phase_ = Phase::stepping;
  return Status::ok;
}

// A frame at the first communication point at or after each multiple of fmu.snapshots_every steps.
Status Instance::write_snapshot_if_due() {
  if (!snapshots_ || sim_->step_count() < next_snapshot_) return Status::ok;
  try {
    snapshots_->write(*sim_);
  } catch (const std::exception& e) {
    return error(e.what());
  }
  next_snapshot_ = (sim_->step_count() / snapshots_every_ + 1) * snapshots_every_;
  return Status::ok;
}

double Instance::time() const { return host_time_; }

// How far the host's clock may be from the FMU's at time t and still be the same time: a host that adds its steps
// up drifts from the FMU's clock by its rounding (2.3e-10 after 100,000 steps of 0.002 from 0). Capped at a quarter
// step (binding from t = 2.5e11 dt on): from t = 1e12 dt on, the relative part alone let a clock a whole step off, or
// a step past the stop time, through.
double Instance::clock_tolerance(double t) const {
  return std::min(1e-6 * sim_->dt() + 1e-12 * std::abs(t), 0.25 * sim_->dt());
}

Status Instance::do_step(const char* function, double current_time, double step, double* reached_time) {
  if (reached_time) *reached_time = time();
  if (Status s = check_phase(function, {Phase::stepping}); s != Status::ok) return s;
  if (!std::isfinite(step) || step < 0)
    return error(fmt::format("{}: communication step size {} is not allowed: a finite value >= 0", function, step));
  if (step / sim_->dt() > Simulation::max_steps)   // refused before stepping: the instance stays usable
    return error(fmt::format("{}: communication step size {} is {:.3g} steps of dt = {:.6g}: allowed at most 1e15 steps "
                             "at a time", function, step, step / sim_->dt(), sim_->dt()));
  const double now = time(), tolerance = clock_tolerance(now);
  if (!std::isfinite(current_time) || std::abs(current_time - now) > tolerance)
    return error(fmt::format("{}: current communication point {:.17g} is not the FMU's time {:.17g}", function, current_time, now));
  // Refused before stepping, so the instance stays where it was. A step that ends on the stop time as the host's clock
  // rounds it (a host adding its steps up passes it by that rounding) is allowed: the time check's tolerance.
  if (const double end = current_time + step; stop_time_ && end > *stop_time_ + clock_tolerance(*stop_time_))
    return error(fmt::format("{}: the step from communication point {} by step size {} would end at {}, past the stop time "
                             "{} the host set up: allowed steps that end at or before the stop time (within the host "
                             "clock's rounding, {:.3g}); the step was not taken", function, current_time, step, end,
                             *stop_time_, clock_tolerance(*stop_time_)));
  // The simulation steps h, which keeps whole multiples of dt whole (the runner's steps, bit for bit). Where it
  // has fallen behind the host's clock by half the tolerance (a host that adds its steps up, whose rounding
  // drifts from ours, or steps far below dt, which the simulation leaves for later), it makes that up too.
  const double behind = (current_time - start_time_) - sim_->time();
  const double duration = std::abs(behind) > 0.5 * tolerance ? std::max(0.0, step + behind) : step;
  // A host's step is often t_{n+1} - t_n of its own clock (fmpy's start + n h), which carries that clock's rounding:
  // at t = 100, or after 16,000 steps of 0.002, h = dt came as 2e-12 dt short, took one shorter step instead of the
  // runner's whole one, and changed the trajectory. Within 1e-9 dt (what a remainder must exceed to be stepped)
  // or a few roundings of the host's time of a whole number of dt, the step is that many whole steps.
  const double dt = sim_->dt(), whole = std::round(duration / dt);
  const double rounding = 1e-9 * dt + 4 * std::numeric_limits<double>::epsilon() * (std::abs(current_time) + step);
  // Any other step is taken in ceil(h / dt) equal steps. Whole steps and one shorter remainder would put a short
  // step beside whole ones, where the contacts' sub-step charges (touching, parting, release), which take the next
  // step to be as long, are off: a head-on collision's restitution comes 6e-3 off at h = 1.001 dt, and 4.5e-3 at
  // 1.37 dt, against 2e-4 at h = dt.
  const double pieces = std::ceil(duration / dt);
  try {
    if (whole >= 1 && std::abs(duration - whole * dt) <= rounding) sim_->step_n(long(whole));
    else if (pieces >= 2) sim_->step_evenly(duration, long(pieces));
    else sim_->step(duration);   // at most dt: one step (none below 1e-9 dt: carried over)
  } catch (const std::exception& e) {
    phase_ = Phase::failed;
    const bool memory = dynamic_cast<const std::bad_alloc*>(&e) != nullptr;
    return error(fmt::format("{} from t = {:.9g} by {:.9g} failed: {}", function, now, step,
                             memory ? out_of_memory_message : e.what()));
  }
  host_time_ = current_time + step;
  log_new_warnings();
  if (reached_time) *reached_time = time();
  return write_snapshot_if_due();
}

Status Instance::terminate() {
  // As FMI 2 and 3 have it: after initialization (from Step Mode, or after a failed step), not in Initialization Mode.
  if (Status s = check_phase("Terminate", {Phase::stepping, Phase::failed}); s != Status::ok) return s;
  phase_ = Phase::terminated;
  snapshots_.reset();   // closed: other readers, and the next instance of this name, may open it from now on
  return Status::ok;
}

Status Instance::reset() {
  scene_ = packaged_;
  pending_controls_.clear();
  dirty_ = true;
  start_time_ = host_time_ = 0;
  stop_time_.reset();   // the experiment is set up again after a reset, as after instantiation
  snapshots_.reset();
  snapshots_every_ = 0;
  phase_ = Phase::instantiated;
  sim_.reset();   // a new experiment: its start-up warnings are logged again
  meanings_said_.clear();
  return ensure_built();
}

Status Instance::check_fmi2_references(std::span<const std::uint32_t> refs) {
  for (std::uint32_t ref : refs)
    if (ref >= table_.variables.size() || table_.variables[ref].role == Role::particle_array) {
      std::vector<std::uint32_t> declared;   // the arrays come last in the table, after every scalar
      for (std::uint32_t r = 0; r < table_.variables.size(); ++r)
        if (table_.variables[r].role != Role::particle_array) declared.push_back(r);
      return error(fmt::format("unknown value reference {}: this FMU's FMI 2 references are 0 to {}{}", ref, declared.back(),
                               ref < table_.variables.size() ? fmt::format(" ({} is an FMI 3 array)", table_.variables[ref].name) : ""));
    }
  return Status::ok;
}

std::optional<std::size_t> Instance::element_count(std::uint32_t ref) const {
  if (ref >= table_.variables.size()) return std::nullopt;
  const FmuVariable& v = table_.variables[ref];
  if (v.role != Role::particle_array) return 1;
  const std::size_t n = sim_ ? sim_->particle_count() : table_.particle_count;
  return v.field == ParticleField::position ? n * std::size_t(table_.dimension) : n;
}

Status Instance::get(std::span<const std::uint32_t> refs, ValueType type, std::span<double> values) {
  std::size_t k = 0;
  for (std::uint32_t ref : refs) {
    if (ref >= table_.variables.size())
      return error(fmt::format("unknown value reference {}: this FMU's references are 0 to {}", ref, table_.variables.size() - 1));
    const FmuVariable& v = table_.variables[ref];
    if (v.type != type && v.role != Role::particle_array)
      return error(fmt::format("variable '{}' (reference {}) has type {}; it was read as {}", v.name, ref, type_name(v.type),
                               type_name(type)));
    // Past the room the call gives, only count (too few values is an error below, like too many).
    if (v.role == Role::snapshot_option) {
      if (k < values.size()) values[k] = double(snapshots_every_);
      ++k;
      continue;
    }
    if (v.role == Role::scene_parameter) {
      if (k < values.size()) values[k] = scene_value(scene_, v);
      ++k;
      continue;
    }
    if (Status s = ensure_built(); s != Status::ok) return s;
    if (v.role == Role::particle_array) {
      const ParticleView p = sim_->particles();
      const auto& data = v.field == ParticleField::position ? p.position : p.radius;
      if (k + data.size() <= values.size()) std::copy(data.begin(), data.end(), values.begin() + std::ptrdiff_t(k));
      k += data.size();
      continue;
    }
    if (k < values.size()) values[k] = v.role == Role::independent ? time() : sim_->get(v.sim_index);
    ++k;
  }
  if (k != values.size()) {
    std::string arrays;   // the usual cause: a host that sized the arrays for another particles.count
    for (std::uint32_t ref : refs)
      if (table_.variables[ref].role == Role::particle_array)
        arrays += fmt::format("{}{} has {}", arrays.empty() ? "" : ", ", table_.variables[ref].name, *element_count(ref));
    if (!arrays.empty())
      arrays = fmt::format(" ({} values, for particles.count = {} in {}D)", arrays,
                           sim_ ? sim_->particle_count() : table_.particle_count, table_.dimension);
    return error(fmt::format("the call passes {} values for variables holding {}{}", values.size(), k, arrays));
  }
  log_new_warnings();   // the outputs' checks (energy, pass-through, softened core) run as they are read
  return Status::ok;
}

void Instance::log_new_warnings(const std::vector<std::string>& said) {
  // The host's logger may call back into this instance to read, which runs the checks, which may add warnings. Each
  // message is taken, and counted, before the logger sees it (else a logger reading an output has the first warning
  // twice, and the next rebuild reads past the list's end).
  while (sim_ && warnings_logged_ < sim_->warnings().size()) {
    const std::string message = sim_->warnings()[warnings_logged_++];
    if (std::find(said.begin(), said.end(), message) != said.end()) continue;
    if (enabled(log_warning)) logger_(Status::warning, log_warning, message);
    warned_ = true;
  }
}

std::vector<std::string> Instance::moved_parameters() const {
  std::vector<std::string> moved;
  for (const FmuVariable& v : table_.variables)
    if (v.role == Role::scene_parameter && scene_value(scene_, v) != scene_value(packaged_, v))
      moved.push_back(fmt::format("{} = {}", v.name, shown_value(v, scene_value(scene_, v))));
  return moved;
}

void Instance::log_new_meanings(const ModelTable& now) {
  // adhesion.force = 0 makes the consolidation cell cohesionless, and P* (the input cell.pressure) is then reduced by
  // k_n, not F0: a host sweeping F0 down to 0 has its target jump by 11 orders of magnitude, which must be said.
  const std::vector<std::string> changed = moved_parameters();   // named as the cause
  for (std::size_t r = 0; r < now.variables.size() && r < table_.variables.size(); ++r) {
    const FmuVariable &is = now.variables[r], &was = table_.variables[r];
    if (is.role == Role::scene_parameter || is.description == was.description) continue;
    const std::string meaning = is.name + ": " + is.description;
    if (std::find(meanings_said_.begin(), meanings_said_.end(), meaning) != meanings_said_.end()) continue;
    meanings_said_.push_back(meaning);
    warn(fmt::format("with the parameter values set ({}), '{}' is: {} (the modelDescription says: {})",
                     fmt::join(changed, ", "), is.name, is.description, was.description));
  }
}

Status Instance::set(std::span<const std::uint32_t> refs, ValueType type, std::span<const double> values) {
  // An array among the references is the reason the counts differ: say so, not that they differ.
  for (const std::uint32_t ref : refs)
    if (ref < table_.variables.size() && table_.variables[ref].role == Role::particle_array)
      return error(fmt::format("'{}' (reference {}) is {}: it cannot be set", table_.variables[ref].name, ref,
                               role_name(Role::particle_array)));
  if (refs.size() != values.size())
    return error(fmt::format("the call passes {} values for {} scalar variables", values.size(), refs.size()));
  // All or nothing: a call with one refused value leaves every variable as it was, those listed before it too. The
  // scene is copied only where a value may go into it (before the steps: a host setting inputs each step pays nothing).
  const bool before_steps = before_the_steps();
  std::optional<Scene> scene_before;
  if (before_steps) scene_before = scene_;
  const bool dirty_before = dirty_;
  auto pending_before = before_steps ? pending_controls_ : decltype(pending_controls_){};   // changes only before too
  const long snapshots_before = snapshots_every_;
  std::vector<std::pair<std::size_t, double>> to_simulation;
  const auto refuse = [&](Status s) {
    if (before_steps) scene_ = std::move(*scene_before), pending_controls_ = std::move(pending_before);
    dirty_ = dirty_before, snapshots_every_ = snapshots_before;
    return s;
  };
  std::vector<std::pair<std::size_t, double>> replaced;   // the simulation's values before the call's
  try {
    for (std::size_t i = 0; i < refs.size(); ++i) {
      const std::uint32_t ref = refs[i];
      if (ref >= table_.variables.size())
        return refuse(error(fmt::format("unknown value reference {}: this FMU's references are 0 to {}", ref, table_.variables.size() - 1)));
      const FmuVariable& v = table_.variables[ref];
      if (v.type != type)
        return refuse(error(fmt::format("variable '{}' (reference {}) has type {}; it was set as {}", v.name, ref, type_name(v.type),
                                        type_name(type))));
      if (Status s = set_one(v, ref, values[i], to_simulation); s != Status::ok) return refuse(s);
    }
    // The engine may still refuse a value its range allows (a cohesionless cell at P* = 0): those it took before go back.
    for (const auto& [index, value] : to_simulation) {
      replaced.emplace_back(index, sim_->get(index));
      sim_->set(index, value);
    }
  } catch (const std::exception& e) {
    for (auto it = replaced.rbegin(); it != replaced.rend(); ++it) {
      try {
        sim_->set(it->first, it->second);   // a value the simulation held: taken again
      } catch (const std::exception&) {
      }
    }
    return refuse(error(e.what()));
  }
  log_new_warnings();   // raised by the values set (a pressure past the contacts' clamp, G past the orbit step rule)
  return Status::ok;
}

Status Instance::set_one(const FmuVariable& v, std::size_t ref, double value,
                         std::vector<std::pair<std::size_t, double>>& to_simulation) {
  const bool before_steps = before_the_steps();
  if (v.role != Role::scene_parameter && v.role != Role::control && v.role != Role::snapshot_option)
    return error(fmt::format("'{}' (reference {}) is {}: it cannot be set", v.name, ref, role_name(v.role)));
  // FMI 3, Configuration Mode: structural parameters only (the others from ExitConfigurationMode on).
  if (phase_ == Phase::configuration && !v.structural)
    return error(fmt::format("'{}' is not a structural parameter: Configuration Mode sets only those{}; set it after "
                             "ExitConfigurationMode (before or in Initialization Mode)", v.name,
                             table_.count_reference != no_index
                                 ? fmt::format(" ('{}')", table_.variables[table_.count_reference].name)
                                 : std::string(" (this FMU has none)")));
  // FMI 3: the structural parameter sizes the arrays the host reads from Initialization Mode on, so it is set before.
  if (fmi3_ && v.structural && phase_ == Phase::initialization)
    return error(fmt::format("'{}' is a structural parameter: it can be set in Configuration Mode (or before it, after "
                             "instantiation), not in {}", v.name, phase_name(phase_)));
  // a real scene key's NaN or inf goes on to the scene's schema, whose message gives the exact allowed range
  const bool schema_judges = !v.scene_key.empty() && v.type == ValueType::real && before_steps;
  if (!std::isfinite(value) && !schema_judges)
    return error(fmt::format("{} = {} is not allowed: a finite value{}", v.name, value,
                             std::isfinite(v.min) || std::isfinite(v.max) ? fmt::format(" in [{}, {}]", v.min, v.max) : ""));
  if (v.type == ValueType::integer && value != std::floor(value))
    return error(fmt::format("{} = {} is not allowed: an integer", v.name, value));
  if (v.type == ValueType::integer && std::fabs(value) > exact_integer_limit)   // rounded already (FMI 3 checks before)
    return error(fmt::format("{} = {:.0f} is out of range: allowed integer in [{}, {}]", v.name, value, v.min, v.max));
  if ((v.role == Role::scene_parameter || v.role == Role::snapshot_option) && !before_steps)
    return error(fmt::format("'{}' is a fixed parameter: it can only be set before the end of initialization, not in {} "
                             "(reset the FMU to change it)", v.name, phase_name(phase_)));
  if (phase_ == Phase::terminated || phase_ == Phase::failed)
    return error(fmt::format("setting '{}' is not allowed in {}", v.name, phase_name(phase_)));
  if (!v.items.empty() && (value < 1 || value > double(v.items.size())))
    return error(fmt::format("{} = {} is out of range: allowed {}", v.name, value, item_values(v)));
  if (v.role == Role::snapshot_option) {
    if (value < 0) return error(fmt::format("{} = {} is not allowed: an integer >= 0 (0 = no snapshots)", v.name, value));
    snapshots_every_ = static_cast<long>(value);
    return Status::ok;
  }
  const bool into_scene = !v.scene_key.empty() && before_steps;
  const bool outside_control_range = v.role == Role::control && (value < v.min || value > v.max);
  const auto control_range_error = [&] {
    return error(fmt::format("{} = {} is out of range: allowed [{}, {}]", v.name, value, v.min, v.max));
  };
  if (outside_control_range && !into_scene) return control_range_error();

  if (into_scene) {   // goes into the scene, checked by the scene's schema (its range first: gravity.G needs > 0 there)
    const std::string text = toml_value(v, value);
    Scene changed = scene_;
    try {
      changed.set_value(v.scene_key, text);
      changed.validate();
    } catch (const SceneError& e) {
      return error(e.what());
    }
    if (outside_control_range) return control_range_error();
    scene_ = std::move(changed);
    dirty_ = true;
    return Status::ok;
  }
  // A control (input or tunable parameter) of the Simulation.
  if (before_steps) pending_controls_[v.sim_index] = value;
  if (sim_ && !dirty_) to_simulation.emplace_back(v.sim_index, value);
  return Status::ok;
}

// The fixed parameters' effective values (a host that sets a default, or sets a value and then the default
// again, has the packaged scene's): a state restores where they are the same.
std::uint64_t Instance::parameter_fingerprint() const {
  std::uint64_t h = fnv1a(instantiation_token(table_));
  for (const FmuVariable& v : table_.variables) {
    if (v.role != Role::scene_parameter) continue;
    h = fnv1a(fmt::format("{}={:.17g};", v.scene_key, scene_value(scene_, v)), h);
  }
  return h;
}

std::vector<double> Instance::parameter_values() const {
  std::vector<double> values;
  for (const FmuVariable& v : table_.variables)
    if (v.role == Role::scene_parameter) values.push_back(scene_value(scene_, v));
  return values;
}

// "name = <state's> in the state, <this instance's> here" for each fixed parameter that differs; "" when the state
// comes from another FMU (its token, or its number of parameters, is not this one's).
std::string Instance::parameter_differences(std::uint64_t token, const std::vector<double>& saved) const {
  const std::vector<double> mine = parameter_values();
  if (token != fnv1a(instantiation_token(table_)) || saved.size() != mine.size()) return {};
  std::vector<std::string> differ;
  std::size_t k = 0;
  for (const FmuVariable& v : table_.variables) {
    if (v.role != Role::scene_parameter) continue;
    if (std::memcmp(&saved[k], &mine[k], sizeof(double)) != 0)
      differ.push_back(fmt::format("{} = {} in the state, {} here", v.name, shown_value(v, saved[k]), shown_value(v, mine[k])));
    ++k;
  }
  return fmt::format("{}", fmt::join(differ, "; "));
}

Status Instance::save(const char* function, SavedState& state) {
  if (phase_ == Phase::failed)
    return error(fmt::format("{} is not allowed in the error state: the simulation is not valid", function));
  if (Status s = ensure_built(); s != Status::ok) return s;
  ByteWriter w;
  w.put(state_magic), w.put(parameter_fingerprint()), w.put(start_time_), w.put(host_time_);
  w.put(fnv1a(instantiation_token(table_))), w.put_vector(parameter_values());   // to name what differs, if refused
  auto bytes = w.take();
  auto body = sim_->save_state();
  bytes.insert(bytes.end(), body.begin(), body.end());
  const std::uint64_t sum = check_sum(bytes);
  const auto* sum_bytes = reinterpret_cast<const std::byte*>(&sum);
  bytes.insert(bytes.end(), sum_bytes, sum_bytes + state_sum);
  state.bytes = std::move(bytes);
  return Status::ok;
}

// Also after a failed step (FMI 2.0, 2.1.3: a host may restart from a state it stored before the error): the
// state replaces the whole simulation, and stepping may go on. Not before the end of initialization: the
// start time given there, and parameters set until then, would replace the restored simulation and its time.
Status Instance::restore(const char* function, const SavedState& state) {
  if (before_the_steps())
    return error(fmt::format("{} is not allowed in {}: a state is set from the end of initialization on "
                             "(after ExitInitializationMode), when the start time and the fixed parameters are final "
                             "(initialization would replace the restored simulation and its time)", function,
                             phase_name(phase_)));
  const bool failed = phase_ == Phase::failed;
  if (Status s = ensure_built(); s != Status::ok) return s;
  if (const std::string defect = state_defect(state.bytes); !defect.empty()) return error(fmt::format("{}: {}", function, defect));
  ByteReader r(std::span(state.bytes).first(state.bytes.size() - state_sum));
  r.get<std::uint64_t>();   // the format word, checked above
  const std::uint64_t fingerprint = r.get<std::uint64_t>();
  const double start = r.get<double>(), host = r.get<double>();
  const std::uint64_t token = r.get<std::uint64_t>();
  std::vector<double> saved;
  r.get_vector(saved);
  if (fingerprint != parameter_fingerprint()) {
    if (const std::string differ = parameter_differences(token, saved); !differ.empty())
      return error(fmt::format("{}: the state was saved with other parameter values ({}); it cannot be restored here: a "
                               "state restores into an instance whose fixed parameters have the values it was saved with",
                               function, differ));
    return error(fmt::format("{}: the state was saved by another FMU (another model, or a build with other variables); "
                             "it cannot be restored here", function));
  }
  const std::size_t body = state_header + 2 * sizeof(std::uint64_t) + saved.size() * sizeof(double);
  if (!std::isfinite(start) || !std::isfinite(host))
    return error(fmt::format("{}: the state's start or current time is not finite", function));
  try {
    sim_->restore_state(std::span(state.bytes).subspan(body, state.bytes.size() - body - state_sum));
  } catch (const std::exception& e) {
    return error(fmt::format("{}: {}", function, e.what()));
  }
  start_time_ = start, host_time_ = host;
  if (failed) phase_ = Phase::stepping;
  return Status::ok;
}

std::vector<std::byte> Instance::serialize(const SavedState& state) const { return state.bytes; }

Status Instance::deserialize(const char* function, std::span<const std::byte> bytes, SavedState& state) {
  if (const std::string defect = state_defect(bytes); !defect.empty()) return error(fmt::format("{}: {}", function, defect));
  state.bytes.assign(bytes.begin(), bytes.end());
  return Status::ok;
}

}  // namespace grains::fmu
