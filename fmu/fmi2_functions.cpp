// The FMI 2.0 API (co-simulation; the model-exchange functions exist and refuse with a message).
// Each function checks its instance, forwards to Instance (the FMU-state ones through fmu_state_calls.cpp, shared
// with FMI 3), and turns any exception into fmi2Error (guarded_call.hpp): nothing thrown ever crosses into the host.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "fmi2_api.hpp"
#include "fmu_state_calls.hpp"
#include "guarded_call.hpp"
#include "instance.hpp"
#include "live_instances.hpp"
#include "resource_location.hpp"

#define GRAINS_FMI2_EXPORT extern "C" __attribute__((visibility("default")))

using grains::fmu::Instance;
using grains::fmu::Status;
using grains::fmu::ValueType;
namespace state_calls = grains::fmu::state_calls;

namespace {

fmi2Status to_fmi2(Status s) { return static_cast<fmi2Status>(s); }

// FMI 2 loggers take a printf format: the message is already formatted, so every '%' is doubled.
std::string escape_percent(const std::string& text) {
  std::string out;
  for (char c : text) out += c == '%' ? std::string("%%") : std::string(1, c);
  return out;
}

template <class F>
fmi2Status guarded(fmi2Component c, const char* function, F&& body) {
  return to_fmi2(grains::fmu::guarded_call(c, function, std::forward<F>(body)));
}

// The most values one get or set passes: they go through an array of doubles, and no array holds more. A larger
// nvr (a negative count passed as size_t, say) is no array the host can have: refused before anything is read or
// allocated. nvr = 2^62 made the reference check read nothing (the span's end wrapped round to its start) and then
// failed in the C++ library, whose message ("cannot create std::vector larger than max_size()") was all the host saw.
constexpr size_t most_values = PTRDIFF_MAX / sizeof(double);

Status check_count(Instance& in, const char* function, size_t nvr) {
  if (nvr <= most_values) return Status::ok;
  return in.error(fmt::format("{}: nvr = {} is more values than an array holds: nvr, the number of references in vr, "
                              "is allowed from 0 to {}", function, nvr, most_values));
}

template <class T>
fmi2Status get_values(fmi2Component c, const char* function, const fmi2ValueReference vr[], size_t nvr, T value[], ValueType type) {
  return guarded(c, function, [&](Instance& in) {
    if (Status s = check_count(in, function, nvr); s != Status::ok) return s;
    if (nvr > 0 && (!vr || !value)) return in.error(fmt::format("{}: null array", function));
    if (Status s = in.check_fmi2_references(std::span<const std::uint32_t>(vr, nvr)); s != Status::ok) return s;
    std::vector<double> v(nvr);
    Status s = in.get(std::span<const std::uint32_t>(vr, nvr), type, v);
    if (s == Status::ok)
      for (size_t i = 0; i < nvr; ++i) value[i] = static_cast<T>(v[i]);
    return s;
  });
}

template <class T>
fmi2Status set_values(fmi2Component c, const char* function, const fmi2ValueReference vr[], size_t nvr, const T value[], ValueType type) {
  return guarded(c, function, [&](Instance& in) {
    if (Status s = check_count(in, function, nvr); s != Status::ok) return s;
    if (nvr > 0 && (!vr || !value)) return in.error(fmt::format("{}: null array", function));
    if (Status s = in.check_fmi2_references(std::span<const std::uint32_t>(vr, nvr)); s != Status::ok) return s;
    std::vector<double> v(value, value + nvr);
    return in.set(std::span<const std::uint32_t>(vr, nvr), type, v);
  });
}

// A status query asks for its one kind with somewhere to put it: a null pointer with the right kind was
// answered "only <kind> is available", naming the kind the host had passed.
Status status_query(Instance& in, const char* function, fmi2StatusKind asked, fmi2StatusKind available,
                    const char* available_name, const void* value) {
  if (asked != available)
    return in.error(fmt::format("{}: status kind {} is not available: only {} ({})", function, int(asked), available_name,
                                int(available)));
  if (!value) return in.error(fmt::format("{}: value is a null pointer: pass where the status goes", function));
  return Status::ok;
}

fmi2Status refuse(fmi2Component c, const char* function, const char* why) {
  return guarded(c, function, [&](Instance& in) { return in.unsupported(function, why); });
}
constexpr const char* not_me = "this FMU is for co-simulation only (no model exchange)";

}  // namespace

GRAINS_FMI2_EXPORT const char* fmi2GetTypesPlatform(void) { return "default"; }
GRAINS_FMI2_EXPORT const char* fmi2GetVersion(void) { return "2.0"; }

GRAINS_FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                                                  const fmi2String categories[]) {
  return guarded(c, "fmi2SetDebugLogging", [&](Instance& in) {
    return in.set_debug_logging(loggingOn != 0, std::span<const char* const>(categories, categories ? nCategories : 0));
  });
}

GRAINS_FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                                                 fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                                                 fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)visible;
  const std::string name = instanceName ? instanceName : "grains";
  fmi2CallbackLogger host_logger = functions ? functions->logger : nullptr;
  fmi2ComponentEnvironment env = functions ? functions->componentEnvironment : nullptr;
  Instance::Logger logger = [host_logger, env, name](Status s, const char* category, const std::string& message) {
    if (host_logger) host_logger(env, name.c_str(), static_cast<fmi2Status>(s), category, escape_percent(message).c_str());
  };
  try {
    if (fmuType != fmi2CoSimulation) {
      logger(Status::error, grains::fmu::log_error, "fmi2Instantiate: this FMU supports co-simulation only (fmuType = fmi2CoSimulation)");
      return nullptr;
    }
    if (grains::fmu::blank_instance_name(instanceName)) {
      logger(Status::error, grains::fmu::log_error, fmt::format("fmi2Instantiate: {}", grains::fmu::blank_instance_name_message));
      return nullptr;
    }
    std::filesystem::path resources = fmuResourceLocation && *fmuResourceLocation
                                          ? grains::fmu::decode_resource_location(fmuResourceLocation)
                                          : grains::fmu::resources_beside_binary();
    return grains::fmu::hand_out(Instance::create("fmi2Instantiate", name, fmuGUID ? fmuGUID : "", resources, logger, loggingOn != 0));
  } catch (const std::exception& e) {
    logger(Status::error, grains::fmu::log_error, fmt::format("fmi2Instantiate: {}", e.what()));
  }
  return nullptr;
}

GRAINS_FMI2_EXPORT void fmi2FreeInstance(fmi2Component c) {
  try {
    grains::fmu::free_instance(c);
  } catch (...) {   // out of memory taking its states out: nothing may reach the host
  }
}

GRAINS_FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                                                  fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  // The tolerance is unused: the FMU steps by the scene's dt.
  (void)toleranceDefined, (void)tolerance;
  return guarded(c, "fmi2SetupExperiment", [&](Instance& in) {
    if (in.phase() != grains::fmu::Phase::instantiated)
      return in.error("fmi2SetupExperiment is only allowed before fmi2EnterInitializationMode");
    const grains::fmu::Experiment experiment{startTime, stopTimeDefined ? std::optional(stopTime) : std::nullopt};
    // refused here, where the host gave it, not at the next call
    if (Status s = in.check_experiment("fmi2SetupExperiment", experiment); s != Status::ok) return s;
    in.fmi2_experiment = experiment;
    return Status::ok;
  });
}

GRAINS_FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2EnterInitializationMode",
                 [&](Instance& in) { return in.enter_initialization("fmi2EnterInitializationMode", in.fmi2_experiment); });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
  return guarded(c, "fmi2ExitInitializationMode", [&](Instance& in) { return in.exit_initialization(); });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
  return guarded(c, "fmi2Terminate", [&](Instance& in) { return in.terminate(); });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c) {
  return guarded(c, "fmi2Reset", [&](Instance& in) {
    in.fmi2_experiment = {};
    return in.reset();
  });
}

GRAINS_FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  return get_values(c, "fmi2GetReal", vr, nvr, value, ValueType::real);
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  return get_values(c, "fmi2GetInteger", vr, nvr, value, ValueType::integer);
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  return get_values(c, "fmi2GetBoolean", vr, nvr, value, ValueType::boolean);
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  (void)vr, (void)value;
  return guarded(c, "fmi2GetString", [&](Instance& in) {
    return nvr == 0 ? Status::ok : in.error("fmi2GetString: this FMU has no String variables");
  });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  return set_values(c, "fmi2SetReal", vr, nvr, value, ValueType::real);
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  return set_values(c, "fmi2SetInteger", vr, nvr, value, ValueType::integer);
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  return set_values(c, "fmi2SetBoolean", vr, nvr, value, ValueType::boolean);
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  (void)vr, (void)value;
  return guarded(c, "fmi2SetString", [&](Instance& in) {
    return nvr == 0 ? Status::ok : in.error("fmi2SetString: this FMU has no String variables");
  });
}

// --- FMU state: fmu_state_calls.cpp ---
GRAINS_FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  return to_fmi2(state_calls::get(c, "fmi2GetFMUstate", "FMUstate", FMUstate));
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
  return to_fmi2(state_calls::set(c, "fmi2SetFMUstate", "FMUstate", FMUstate));
}
GRAINS_FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* FMUstate) {
  return to_fmi2(state_calls::free(c, "fmi2FreeFMUstate", FMUstate));
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t* size) {
  return to_fmi2(state_calls::serialized_size(c, "fmi2SerializedFMUstateSize", FMUstate, size));
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
  return to_fmi2(state_calls::serialize(c, "fmi2SerializeFMUstate", FMUstate, serializedState, size));
}
GRAINS_FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                                      fmi2FMUstate* FMUstate) {
  return to_fmi2(state_calls::deserialize(c, "fmi2DeSerializeFMUstate", serializedState, size, FMUstate));
}

GRAINS_FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference[], size_t,
                                                           const fmi2ValueReference[], size_t, const fmi2Real[], fmi2Real[]) {
  return refuse(c, "fmi2GetDirectionalDerivative", "a DEM step has no useful derivative (providesDirectionalDerivative = false)");
}

// --- model exchange: not provided ---
GRAINS_FMI2_EXPORT fmi2Status fmi2EnterEventMode(fmi2Component c) { return refuse(c, "fmi2EnterEventMode", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo*) { return refuse(c, "fmi2NewDiscreteStates", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return refuse(c, "fmi2EnterContinuousTimeMode", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean, fmi2Boolean*, fmi2Boolean*) {
  return refuse(c, "fmi2CompletedIntegratorStep", not_me);
}
GRAINS_FMI2_EXPORT fmi2Status fmi2SetTime(fmi2Component c, fmi2Real) { return refuse(c, "fmi2SetTime", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real[], size_t) { return refuse(c, "fmi2SetContinuousStates", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real[], size_t) { return refuse(c, "fmi2GetDerivatives", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real[], size_t) { return refuse(c, "fmi2GetEventIndicators", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real[], size_t) { return refuse(c, "fmi2GetContinuousStates", not_me); }
GRAINS_FMI2_EXPORT fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real[], size_t) {
  return refuse(c, "fmi2GetNominalsOfContinuousStates", not_me);
}

// --- co-simulation ---
GRAINS_FMI2_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference[], size_t,
                                                          const fmi2Integer[], const fmi2Real[]) {
  return refuse(c, "fmi2SetRealInputDerivatives", "inputs are held constant over a communication step (canInterpolateInputs = false)");
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference[], size_t,
                                                           const fmi2Integer[], fmi2Real[]) {
  return refuse(c, "fmi2GetRealOutputDerivatives", "output derivatives are not provided (maxOutputDerivativeOrder = 0)");
}
GRAINS_FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                                         fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  (void)noSetFMUStatePriorToCurrentPoint;
  return guarded(c, "fmi2DoStep", [&](Instance& in) {
    return in.do_step("fmi2DoStep", currentCommunicationPoint, communicationStepSize, nullptr);
  });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2CancelStep(fmi2Component c) {
  return refuse(c, "fmi2CancelStep", "fmi2DoStep always completes before returning (no asynchronous steps)");
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
  return guarded(c, "fmi2GetStatus", [&](Instance& in) {
    if (Status e = status_query(in, "fmi2GetStatus", s, fmi2DoStepStatus, "fmi2DoStepStatus", value); e != Status::ok) return e;
    *value = fmi2OK;   // steps are synchronous: a returned fmi2DoStep is complete
    return Status::ok;
  });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
  return guarded(c, "fmi2GetRealStatus", [&](Instance& in) {
    if (Status e = status_query(in, "fmi2GetRealStatus", s, fmi2LastSuccessfulTime, "fmi2LastSuccessfulTime", value);
        e != Status::ok)
      return e;
    *value = in.time();
    return Status::ok;
  });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind, fmi2Integer*) {
  return refuse(c, "fmi2GetIntegerStatus", "there is no integer status");
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value) {
  return guarded(c, "fmi2GetBooleanStatus", [&](Instance& in) {
    if (Status e = status_query(in, "fmi2GetBooleanStatus", s, fmi2Terminated, "fmi2Terminated", value); e != Status::ok)
      return e;
    *value = 0;   // the FMU never asks the host to stop
    return Status::ok;
  });
}
GRAINS_FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind, fmi2String*) {
  return refuse(c, "fmi2GetStringStatus", "there is no string status (steps are never pending)");
}
