// One FMU instance, independent of the FMI version: the packaged scene plus the host's parameter
// overrides, the Simulation built from them, the FMI state machine, and logging through the host.
// fmi2_functions.cpp and fmi3_functions.cpp translate the C calls into these methods. Nothing here
// is global: every instance owns all its state, so many instances can live in one process.
#pragma once
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "model_variables.hpp"
#include "snapshot_output.hpp"

namespace grains::fmu {

enum class Status { ok, warning, discard, error, fatal };   // same order as fmi2Status / fmi3Status

// The states of the co-simulation state machine shared by FMI 2 and 3 (configuration is FMI 3 only).
enum class Phase { instantiated, configuration, initialization, stepping, terminated, failed };

// Log categories declared in modelDescription.xml.
inline constexpr const char* log_error = "logStatusError";
inline constexpr const char* log_warning = "logStatusWarning";
inline constexpr const char* log_calls = "logCalls";
inline const std::vector<std::pair<const char*, const char*>>& log_categories() {
  static const std::vector<std::pair<const char*, const char*>> c = {
      {log_error, "errors: illegal calls, bad values, a simulation that cannot continue"},
      {log_warning, "warnings raised by the engine (time step rule, clamped overlaps)"},
      {log_calls, "every FMI call (verbose)"}};
  return c;
}

// The runner's words for it (runner/main.cpp), with the FMU's parameter.
inline constexpr const char* out_of_memory_message =
    "out of memory: the scene needs more memory than this machine gives the FMU (fewer particles: a smaller particles.count)";

// FMI 2 and 3 want an instance name with at least one character that is not white space; what the
// instantiate functions say otherwise.
inline bool blank_instance_name(const char* name) {
  for (; name && *name; ++name)
    if (!std::isspace(static_cast<unsigned char>(*name))) return false;
  return true;
}
inline constexpr const char* blank_instance_name_message =
    "instanceName must be a non-empty string, with at least one character that is not white space (it names the "
    "instance in the messages)";

// The experiment the host sets up (FMI 2: fmi2SetupExperiment; FMI 3: fmi3EnterInitializationMode). The stop time,
// where the host defines one, is the last time it may step to: a step past it is refused (FMI 2.0 and 3.0 both say
// the FMU returns an error if the host computes past it).
struct Experiment {
  double start = 0;
  std::optional<double> stop;   // none: the host did not define one
};

// A saved FMU state: one byte string, the engine's state behind a header that identifies the scene and parameters
// it belongs to, with a check sum (Instance::save, instance.cpp).
struct SavedState {
  std::vector<std::byte> bytes;
};

class Instance {
 public:
  // Receives pre-formatted messages; the FMI layer adds the instance name and escapes as needed.
  using Logger = std::function<void(Status, const char* category, const std::string& message)>;

  // Returns nullptr (after logging why, named after `function`, the host's instantiate call) when the resources or
  // the token do not fit.
  static std::unique_ptr<Instance> create(const char* function, std::string name, std::string_view token,
                                          const std::filesystem::path& resources, Logger logger, bool logging_on);

  const std::string& name() const { return name_; }
  const ModelTable& table() const { return table_; }
  Phase phase() const { return phase_; }

  Status set_debug_logging(bool on, std::span<const char* const> categories);

  Status enter_configuration();
  Status exit_configuration();
  // Why `experiment` cannot be run (a start or stop time that is not finite, a stop before the start), as an error
  // naming `function`; ok when it can.
  Status check_experiment(const char* function, const Experiment& experiment);
  Status enter_initialization(const char* function, const Experiment& experiment);
  Status exit_initialization();
  Status do_step(const char* function, double current_time, double step, double* reached_time);
  Status terminate();
  Status reset();

  // Values travel as doubles; `type` is the type of the calling FMI function, checked against the variable.
  // `values` receives or holds every element of the listed variables in order (arrays flattened).
  Status get(std::span<const std::uint32_t> refs, ValueType type, std::span<double> values);
  Status set(std::span<const std::uint32_t> refs, ValueType type, std::span<const double> values);
  // FMI 2 declares no arrays: a reference to one is refused as unknown there (whatever its size).
  Status check_fmi2_references(std::span<const std::uint32_t> refs);
  // Element count of a variable (1 for scalars) for sizing array calls; nullopt for an unknown reference.
  std::optional<std::size_t> element_count(std::uint32_t ref) const;

  // `function` is the FMI function the host called (fmi2SetFMUstate, fmi3SetFMUState): the messages name it, in its
  // version's spelling, as do_step's do.
  Status save(const char* function, SavedState& state);
  Status restore(const char* function, const SavedState& state);
  std::vector<std::byte> serialize(const SavedState& state) const;
  Status deserialize(const char* function, std::span<const std::byte> bytes, SavedState& state);

  double time() const;
  // The thread inside a call on this instance (none: no call), and whether the host asked to free it meanwhile; both
  // read and written under the registry's lock only (live_instances.cpp). FMI 2 and 3 allow one call at a time per
  // instance; a host that stepped one instance from two threads (Ecos, two slots loaded from one FMU path) corrupted
  // the heap and aborted.
  std::thread::id caller{};
  bool free_asked = false;
  const Logger& logger() const { return logger_; }
  Experiment fmi2_experiment;   // FMI 2: what fmi2SetupExperiment gave, for fmi2EnterInitializationMode
  // Errors for FMI functions this FMU does not support, with the reason.
  Status unsupported(const char* function, const char* why);
  // Logged as an error and named after the host's call being answered (answering()), unless the message starts with
  // that call's name already: the host's log interleaves many calls, and "unknown value reference 9" alone does not
  // say which one was refused.
  Status error(const std::string& message);
  void warn(const std::string& message);   // logged as the calls' warnings are; the call returns Warning
  // The call now answered (nullptr: none); returns the one before, for a call made inside another (a host's logger
  // calling back into the instance) to restore.
  const char* answering(const char* function) { return std::exchange(answering_, function); }
  void log_new_warnings(const std::vector<std::string>& said = {});   // sim_'s warnings not yet passed to the logger
  // The inputs and outputs whose description in `now` (the table of the scene with the host's values) differs from
  // the modelDescription's, each logged once as a warning: a parameter can change what a variable means.
  void log_new_meanings(const ModelTable& now);
  // "name = value" of each fixed parameter the host moved from the packaged scene's value.
  std::vector<std::string> moved_parameters() const;
  // Whether warnings were passed (logged, unless the host switched logStatusWarning off) since the last take: the
  // call that raised them returns fmi2Warning / fmi3Warning instead of OK (guarded_call).
  bool take_warned() { return std::exchange(warned_, false); }
  void log_call(const std::string& call);

 private:
  Instance(std::string name, Logger logger, bool logging_on, bool fmi3)
      : name_(std::move(name)), logger_(std::move(logger)), logging_on_(logging_on), fmi3_(fmi3) {}
  Status ensure_built();
  // Before Step Mode: instantiated, in Configuration or in Initialization Mode (the fixed parameters still open).
  bool before_the_steps() const {
    return phase_ == Phase::instantiated || phase_ == Phase::configuration || phase_ == Phase::initialization;
  }
  Status check_phase(const char* function, std::initializer_list<Phase> allowed);
  // Applies one value to the instance (scene_, pending controls, the snapshot option); a control for the built
  // simulation is appended to `to_simulation`, which set() applies once every value of the call is accepted.
  Status set_one(const FmuVariable& v, std::size_t ref, double value, std::vector<std::pair<std::size_t, double>>& to_simulation);
  std::uint64_t parameter_fingerprint() const;
  std::vector<double> parameter_values() const;   // the fixed parameters', in the table's order
  std::string parameter_differences(std::uint64_t token, const std::vector<double>& saved) const;
  bool enabled(const char* category) const;
  double clock_tolerance(double t) const;

  std::string name_;
  const char* answering_ = nullptr;
  Logger logger_;
  bool logging_on_ = false;
  bool fmi3_ = false;   // instantiated through FMI 3: particles.count is a structural parameter there
  std::map<std::string, bool> categories_;   // empty = all categories on
  Scene packaged_;            // the scene in resources/, as shipped
  Scene scene_;               // packaged_ plus the host's overrides
  std::map<std::size_t, double> pending_controls_;   // control values set before the Simulation exists
  std::unique_ptr<Simulation> sim_;
  // sim_'s warnings passed to the logger so far: those raised since, by a step or by the checks that run as a host
  // reads the outputs (energy, pass-through), are logged at the end of that DoStep or read, else those of the last
  // read before Terminate never reach the host.
  std::size_t warnings_logged_ = 0;
  // The inputs' and outputs' new meanings ("name: description") logged so far, each once until a reset.
  std::vector<std::string> meanings_said_;
  bool warned_ = false;   // see take_warned()
  bool dirty_ = true;         // scene_ changed since sim_ was built
  ModelTable table_;          // of the packaged scene: references and types never change
  Phase phase_ = Phase::instantiated;
  double start_time_ = 0;     // host time = start_time_ + simulation time, to within the host's rounding
  // The host's time of the FMU: the last communication point reached (current + h as the host passed
  // them), which time() reports; the simulation follows it (do_step).
  double host_time_ = 0;
  // The host's stop time (none when it defined none): part of the experiment's setup, not of a saved FMU state, so a
  // state restored here keeps this instance's stop time.
  std::optional<double> stop_time_;
  long snapshots_every_ = 0;  // fmu.snapshots_every
  long next_snapshot_ = 0;
  std::unique_ptr<SnapshotOutput> snapshots_;
  Status write_snapshot_if_due();
};

}  // namespace grains::fmu
