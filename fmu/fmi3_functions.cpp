// The FMI 3.0 API (co-simulation; model exchange, scheduled execution, clocks and event mode exist
// and refuse with a message). Each function checks its instance, forwards to Instance (the FMU-state ones through
// fmu_state_calls.cpp, shared with FMI 2), and turns any exception into fmi3Error (guarded_call.hpp): nothing thrown
// ever crosses into the host.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "fmi3_api.hpp"
#include "fmu_state_calls.hpp"
#include "guarded_call.hpp"
#include "instance.hpp"
#include "live_instances.hpp"
#include "resource_location.hpp"

#define GRAINS_FMI3_EXPORT extern "C" __attribute__((visibility("default")))

using grains::fmu::Instance;
using grains::fmu::Role;
using grains::fmu::Status;
using grains::fmu::ValueType;
namespace state_calls = grains::fmu::state_calls;

namespace {

fmi3Status to_fmi3(Status s) { return static_cast<fmi3Status>(s); }

template <class F>
fmi3Status guarded(fmi3Instance c, const char* function, F&& body) {
  return to_fmi3(grains::fmu::guarded_call(c, function, std::forward<F>(body)));
}

// The FMI 3 type of each variable, as written in modelDescription.xml (see model_description.cpp).
enum class Fmi3Type { Float64, Int64, UInt64, Boolean };
Fmi3Type fmi3_type(const grains::fmu::FmuVariable& v) {
  if (v.type == ValueType::boolean) return Fmi3Type::Boolean;
  if (v.type == ValueType::integer) return v.structural ? Fmi3Type::UInt64 : Fmi3Type::Int64;
  return Fmi3Type::Float64;
}
const char* fmi3_type_name(Fmi3Type t) {
  switch (t) {
    case Fmi3Type::Float64: return "Float64";
    case Fmi3Type::Int64: return "Int64";
    case Fmi3Type::UInt64: return "UInt64";
    default: return "Boolean";
  }
}

Status check_types(Instance& in, const char* function, const fmi3ValueReference vr[], size_t nvr, Fmi3Type type) {
  const auto& vars = in.table().variables;
  for (size_t i = 0; i < nvr; ++i) {
    if (vr[i] >= vars.size())
      return in.error(fmt::format("{}: unknown value reference {}: this FMU's references are 0 to {}", function, vr[i], vars.size() - 1));
    if (fmi3_type(vars[vr[i]]) != type)
      return in.error(fmt::format("{}: variable '{}' (reference {}) has type {}", function, vars[vr[i]].name, vr[i],
                                  fmi3_type_name(fmi3_type(vars[vr[i]]))));
  }
  return Status::ok;
}

template <class T>
fmi3Status get_values(fmi3Instance c, const char* function, const fmi3ValueReference vr[], size_t nvr, T values[],
                      size_t nValues, Fmi3Type type) {
  return guarded(c, function, [&](Instance& in) {
    if ((nvr > 0 && !vr) || (nValues > 0 && !values)) return in.error(fmt::format("{}: null array", function));
    if (Status s = check_types(in, function, vr, nvr, type); s != Status::ok) return s;
    const ValueType vt = type == Fmi3Type::Float64 ? ValueType::real : type == Fmi3Type::Boolean ? ValueType::boolean : ValueType::integer;
    // The count is checked before nValues values are made: a wrong nValues from the host had the FMU allocate
    // and zero that many doubles first. Float64 values go straight into the host's array (Instance::get writes
    // within nValues only and compares the counts); the other types are scalars, one value per reference.
    if constexpr (std::is_same_v<T, fmi3Float64>) {
      return in.get(std::span<const std::uint32_t>(vr, nvr), vt, std::span<double>(values, nValues));
    } else {
      if (nValues != nvr) return in.error(fmt::format("the call passes {} values for variables holding {}", nValues, nvr));
      std::vector<double> v(nValues);
      Status s = in.get(std::span<const std::uint32_t>(vr, nvr), vt, v);
      if (s == Status::ok)
        for (size_t i = 0; i < nValues; ++i) values[i] = static_cast<T>(v[i]);
      return s;
    }
  });
}

template <class T>
bool exact_in_double(T integer) {
  constexpr T limit = T(grains::fmu::exact_integer_limit);
  if constexpr (std::is_signed_v<T>) return integer >= -limit && integer <= limit;
  return integer <= limit;
}

template <class T>
fmi3Status set_values(fmi3Instance c, const char* function, const fmi3ValueReference vr[], size_t nvr, const T values[],
                      size_t nValues, Fmi3Type type) {
  return guarded(c, function, [&](Instance& in) {
    if ((nvr > 0 && !vr) || (nValues > 0 && !values)) return in.error(fmt::format("{}: null array", function));
    if (Status s = check_types(in, function, vr, nvr, type); s != Status::ok) return s;
    const ValueType vt = type == Fmi3Type::Float64 ? ValueType::real : type == Fmi3Type::Boolean ? ValueType::boolean : ValueType::integer;
    // The count is checked before the values are read: copying all nValues read past the array of a host that
    // passed a wrong nValues (SIGSEGV in the host). Float64 values are read in place (Instance::set compares the
    // counts first); the other types are scalars, one value per reference.
    if constexpr (std::is_same_v<T, fmi3Float64>) {
      return in.set(std::span<const std::uint32_t>(vr, nvr), vt, std::span<const double>(values, nValues));
    } else {
      if (nValues != nvr) return in.error(fmt::format("the call passes {} values for {} scalar variables", nValues, nvr));
      // Beyond what a double holds exactly (a negative count passed as unsigned among them): refused before the
      // conversion rounds it, and named as passed.
      if constexpr (std::is_same_v<T, fmi3Int64> || std::is_same_v<T, fmi3UInt64>)
        for (size_t i = 0; i < nvr; ++i)
          if (!exact_in_double(values[i])) {
            const auto& var = in.table().variables[vr[i]];
            return in.error(fmt::format("{}: {} = {} is out of range: allowed integer in [{}, {}]", function, var.name,
                                        values[i], var.min, var.max));
          }
      std::vector<double> v(values, values + nValues);
      return in.set(std::span<const std::uint32_t>(vr, nvr), vt, v);
    }
  });
}

// Types this FMU has no variables of: an empty call is fine, anything else names the problem.
fmi3Status no_such_type(fmi3Instance c, const char* function, size_t nvr, const char* type) {
  return guarded(c, function, [&](Instance& in) {
    return nvr == 0 ? Status::ok : in.error(fmt::format("{}: this FMU has no {} variables", function, type));
  });
}

fmi3Status refuse(fmi3Instance c, const char* function, const char* why) {
  return guarded(c, function, [&](Instance& in) { return in.unsupported(function, why); });
}
constexpr const char* not_me = "this FMU is for co-simulation only (no model exchange)";
constexpr const char* no_clocks = "this FMU has no clocks";
constexpr const char* no_events = "this FMU has no event mode (hasEventMode = false)";

}  // namespace

GRAINS_FMI3_EXPORT const char* fmi3GetVersion(void) { return "3.0"; }

GRAINS_FMI3_EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories,
                                                  const fmi3String categories[]) {
  return guarded(c, "fmi3SetDebugLogging", [&](Instance& in) {
    return in.set_debug_logging(loggingOn, std::span<const char* const>(categories, categories ? nCategories : 0));
  });
}

GRAINS_FMI3_EXPORT fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String, fmi3String, fmi3Boolean,
                                                             fmi3Boolean, fmi3InstanceEnvironment instanceEnvironment,
                                                             fmi3LogMessageCallback logMessage) {
  if (logMessage)
    logMessage(instanceEnvironment, fmi3Error, grains::fmu::log_error,
               fmt::format("fmi3InstantiateModelExchange ({}): this FMU supports co-simulation only", instanceName ? instanceName : "").c_str());
  return nullptr;
}

GRAINS_FMI3_EXPORT fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
    fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
    fmi3IntermediateUpdateCallback intermediateUpdate) {
  (void)visible, (void)earlyReturnAllowed, (void)requiredIntermediateVariables, (void)intermediateUpdate;
  const std::string name = instanceName ? instanceName : "grains";
  Instance::Logger logger = [logMessage, instanceEnvironment](Status s, const char* category, const std::string& message) {
    if (logMessage) logMessage(instanceEnvironment, static_cast<fmi3Status>(s), category, message.c_str());
  };
  try {
    if (grains::fmu::blank_instance_name(instanceName)) {
      logger(Status::error, grains::fmu::log_error, fmt::format("fmi3InstantiateCoSimulation: {}", grains::fmu::blank_instance_name_message));
      return nullptr;
    }
    if (eventModeUsed) {
      logger(Status::error, grains::fmu::log_error, "fmi3InstantiateCoSimulation: eventModeUsed = true, but this FMU has no event mode");
      return nullptr;
    }
    if (nRequiredIntermediateVariables > 0) {
      logger(Status::error, grains::fmu::log_error, "fmi3InstantiateCoSimulation: this FMU provides no intermediate variable access");
      return nullptr;
    }
    std::filesystem::path resources = resourcePath && *resourcePath ? grains::fmu::decode_resource_location(resourcePath)
                                                                    : grains::fmu::resources_beside_binary();
    return grains::fmu::hand_out(Instance::create("fmi3InstantiateCoSimulation", name, instantiationToken ? instantiationToken : "", resources, logger, loggingOn));
  } catch (const std::exception& e) {
    logger(Status::error, grains::fmu::log_error, fmt::format("fmi3InstantiateCoSimulation: {}", e.what()));
  }
  return nullptr;
}

GRAINS_FMI3_EXPORT fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String, fmi3String, fmi3Boolean,
                                                                  fmi3Boolean, fmi3InstanceEnvironment instanceEnvironment,
                                                                  fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback,
                                                                  fmi3LockPreemptionCallback, fmi3UnlockPreemptionCallback) {
  if (logMessage)
    logMessage(instanceEnvironment, fmi3Error, grains::fmu::log_error,
               fmt::format("fmi3InstantiateScheduledExecution ({}): this FMU supports co-simulation only", instanceName ? instanceName : "").c_str());
  return nullptr;
}

GRAINS_FMI3_EXPORT void fmi3FreeInstance(fmi3Instance c) {
  try {
    grains::fmu::free_instance(c);
  } catch (...) {   // out of memory taking its states out: nothing may reach the host
  }
}

GRAINS_FMI3_EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean, fmi3Float64, fmi3Float64 startTime,
                                                          fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  // The tolerance is unused: the FMU steps by the scene's dt.
  const grains::fmu::Experiment experiment{startTime, stopTimeDefined ? std::optional(stopTime) : std::nullopt};
  return guarded(c, "fmi3EnterInitializationMode",
                 [&](Instance& in) { return in.enter_initialization("fmi3EnterInitializationMode", experiment); });
}
GRAINS_FMI3_EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
  return guarded(c, "fmi3ExitInitializationMode", [&](Instance& in) { return in.exit_initialization(); });
}
GRAINS_FMI3_EXPORT fmi3Status fmi3EnterEventMode(fmi3Instance c) { return refuse(c, "fmi3EnterEventMode", no_events); }
GRAINS_FMI3_EXPORT fmi3Status fmi3Terminate(fmi3Instance c) {
  return guarded(c, "fmi3Terminate", [&](Instance& in) { return in.terminate(); });
}
GRAINS_FMI3_EXPORT fmi3Status fmi3Reset(fmi3Instance c) {
  return guarded(c, "fmi3Reset", [&](Instance& in) { return in.reset(); });
}

#define GRAINS_FMI3_GET_SET(Name, CType, Kind)                                                                      \
  GRAINS_FMI3_EXPORT fmi3Status fmi3Get##Name(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, CType values[], \
                                              size_t nValues) {                                                     \
    return get_values(c, "fmi3Get" #Name, vr, nvr, values, nValues, Fmi3Type::Kind);                               \
  }                                                                                                                 \
  GRAINS_FMI3_EXPORT fmi3Status fmi3Set##Name(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,           \
                                              const CType values[], size_t nValues) {                               \
    return set_values(c, "fmi3Set" #Name, vr, nvr, values, nValues, Fmi3Type::Kind);                               \
  }
GRAINS_FMI3_GET_SET(Float64, fmi3Float64, Float64)
GRAINS_FMI3_GET_SET(Int64, fmi3Int64, Int64)
GRAINS_FMI3_GET_SET(UInt64, fmi3UInt64, UInt64)
GRAINS_FMI3_GET_SET(Boolean, fmi3Boolean, Boolean)

#define GRAINS_FMI3_NO_TYPE(Name, CType)                                                                               \
  GRAINS_FMI3_EXPORT fmi3Status fmi3Get##Name(fmi3Instance c, const fmi3ValueReference[], size_t nvr, CType[], size_t) { \
    return no_such_type(c, "fmi3Get" #Name, nvr, #Name);                                                               \
  }                                                                                                                    \
  GRAINS_FMI3_EXPORT fmi3Status fmi3Set##Name(fmi3Instance c, const fmi3ValueReference[], size_t nvr, const CType[], size_t) { \
    return no_such_type(c, "fmi3Set" #Name, nvr, #Name);                                                               \
  }
GRAINS_FMI3_NO_TYPE(Float32, fmi3Float32)
GRAINS_FMI3_NO_TYPE(Int8, fmi3Int8)
GRAINS_FMI3_NO_TYPE(UInt8, fmi3UInt8)
GRAINS_FMI3_NO_TYPE(Int16, fmi3Int16)
GRAINS_FMI3_NO_TYPE(UInt16, fmi3UInt16)
GRAINS_FMI3_NO_TYPE(Int32, fmi3Int32)
GRAINS_FMI3_NO_TYPE(UInt32, fmi3UInt32)
GRAINS_FMI3_NO_TYPE(String, fmi3String)

GRAINS_FMI3_EXPORT fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference[], size_t nvr, size_t[], fmi3Binary[], size_t) {
  return no_such_type(c, "fmi3GetBinary", nvr, "Binary");
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference[], size_t nvr, const size_t[],
                                            const fmi3Binary[], size_t) {
  return no_such_type(c, "fmi3SetBinary", nvr, "Binary");
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference[], size_t nvr, fmi3Clock[]) {
  return no_such_type(c, "fmi3GetClock", nvr, "Clock");
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference[], size_t nvr, const fmi3Clock[]) {
  return no_such_type(c, "fmi3SetClock", nvr, "Clock");
}

GRAINS_FMI3_EXPORT fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference, size_t*) {
  return refuse(c, "fmi3GetNumberOfVariableDependencies", "dependencies are not declared (every output depends on every input)");
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference, size_t[], fmi3ValueReference[],
                                                          size_t[], fmi3DependencyKind[], size_t) {
  return refuse(c, "fmi3GetVariableDependencies", "dependencies are not declared (every output depends on every input)");
}

// --- FMU state: fmu_state_calls.cpp ---
GRAINS_FMI3_EXPORT fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState* FMUState) {
  return to_fmi3(state_calls::get(c, "fmi3GetFMUState", "FMUState", FMUState));
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState FMUState) {
  return to_fmi3(state_calls::set(c, "fmi3SetFMUState", "FMUState", FMUState));
}
GRAINS_FMI3_EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState* FMUState) {
  return to_fmi3(state_calls::free(c, "fmi3FreeFMUState", FMUState));
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState FMUState, size_t* size) {
  return to_fmi3(state_calls::serialized_size(c, "fmi3SerializedFMUStateSize", FMUState, size));
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
  return to_fmi3(state_calls::serialize(c, "fmi3SerializeFMUState", FMUState, serializedState, size));
}
GRAINS_FMI3_EXPORT fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                                      fmi3FMUState* FMUState) {
  return to_fmi3(state_calls::deserialize(c, "fmi3DeserializeFMUState", serializedState, size, FMUState));
}

GRAINS_FMI3_EXPORT fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3ValueReference[],
                                                           size_t, const fmi3Float64[], size_t, fmi3Float64[], size_t) {
  return refuse(c, "fmi3GetDirectionalDerivative", "a DEM step has no useful derivative (providesDirectionalDerivatives = false)");
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3ValueReference[],
                                                       size_t, const fmi3Float64[], size_t, fmi3Float64[], size_t) {
  return refuse(c, "fmi3GetAdjointDerivative", "a DEM step has no useful derivative (providesAdjointDerivatives = false)");
}

GRAINS_FMI3_EXPORT fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
  return guarded(c, "fmi3EnterConfigurationMode", [&](Instance& in) { return in.enter_configuration(); });
}
GRAINS_FMI3_EXPORT fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
  return guarded(c, "fmi3ExitConfigurationMode", [&](Instance& in) { return in.exit_configuration(); });
}

// --- clocks and discrete states: none ---
GRAINS_FMI3_EXPORT fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3Float64[], fmi3IntervalQualifier[]) {
  return refuse(c, "fmi3GetIntervalDecimal", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3UInt64[], fmi3UInt64[],
                                                      fmi3IntervalQualifier[]) {
  return refuse(c, "fmi3GetIntervalFraction", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3Float64[]) {
  return refuse(c, "fmi3GetShiftDecimal", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference[], size_t, fmi3UInt64[], fmi3UInt64[]) {
  return refuse(c, "fmi3GetShiftFraction", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3Float64[]) {
  return refuse(c, "fmi3SetIntervalDecimal", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3UInt64[],
                                                      const fmi3UInt64[]) {
  return refuse(c, "fmi3SetIntervalFraction", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3Float64[]) {
  return refuse(c, "fmi3SetShiftDecimal", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3UInt64[],
                                                   const fmi3UInt64[]) {
  return refuse(c, "fmi3SetShiftFraction", no_clocks);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) { return refuse(c, "fmi3EvaluateDiscreteStates", no_events); }
GRAINS_FMI3_EXPORT fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean*, fmi3Boolean*, fmi3Boolean*, fmi3Boolean*,
                                                       fmi3Boolean*, fmi3Float64*) {
  return refuse(c, "fmi3UpdateDiscreteStates", no_events);
}

// --- model exchange: not provided ---
GRAINS_FMI3_EXPORT fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { return refuse(c, "fmi3EnterContinuousTimeMode", not_me); }
GRAINS_FMI3_EXPORT fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean, fmi3Boolean*, fmi3Boolean*) {
  return refuse(c, "fmi3CompletedIntegratorStep", not_me);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64) { return refuse(c, "fmi3SetTime", not_me); }
GRAINS_FMI3_EXPORT fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64[], size_t) { return refuse(c, "fmi3SetContinuousStates", not_me); }
GRAINS_FMI3_EXPORT fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64[], size_t) {
  return refuse(c, "fmi3GetContinuousStateDerivatives", not_me);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64[], size_t) { return refuse(c, "fmi3GetEventIndicators", not_me); }
GRAINS_FMI3_EXPORT fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64[], size_t) { return refuse(c, "fmi3GetContinuousStates", not_me); }
GRAINS_FMI3_EXPORT fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64[], size_t) {
  return refuse(c, "fmi3GetNominalsOfContinuousStates", not_me);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t*) {
  return refuse(c, "fmi3GetNumberOfEventIndicators", not_me);
}
GRAINS_FMI3_EXPORT fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t*) {
  return refuse(c, "fmi3GetNumberOfContinuousStates", not_me);
}

// --- co-simulation ---
GRAINS_FMI3_EXPORT fmi3Status fmi3EnterStepMode(fmi3Instance c) { return refuse(c, "fmi3EnterStepMode", no_events); }
GRAINS_FMI3_EXPORT fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference[], size_t, const fmi3Int32[],
                                                       fmi3Float64[], size_t) {
  return refuse(c, "fmi3GetOutputDerivatives", "output derivatives are not provided (maxOutputDerivativeOrder = 0)");
}
GRAINS_FMI3_EXPORT fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                                         fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* eventHandlingNeeded,
                                         fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn, fmi3Float64* lastSuccessfulTime) {
  (void)noSetFMUStatePriorToCurrentPoint;
  return guarded(c, "fmi3DoStep", [&](Instance& in) {
    if (eventHandlingNeeded) *eventHandlingNeeded = false;
    if (terminateSimulation) *terminateSimulation = false;
    if (earlyReturn) *earlyReturn = false;
    double reached = 0;
    Status s = in.do_step("fmi3DoStep", currentCommunicationPoint, communicationStepSize, &reached);
    if (lastSuccessfulTime) *lastSuccessfulTime = reached;
    return s;
  });
}
GRAINS_FMI3_EXPORT fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference, fmi3Float64) {
  return refuse(c, "fmi3ActivateModelPartition", "this FMU is for co-simulation only (no scheduled execution)");
}
