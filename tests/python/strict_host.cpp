// A small FMI host that follows the standards' calling sequence to the letter, for the FMUs as another
// importer than fmpy sees them. Every call must return OK and no message of warning or worse may come (any
// does: listed on stderr, exit status 1). It prints the outputs at every communication point as hex floats
// (bit-exact), one row per point: "t,value,...".
//
//   strict_host VERSION LIBRARY RESOURCES TOKEN [options]
//     --set REF=VALUE        a Float64/Real parameter or input, set before initialization (FMI 3: after configuration)
//     --count REF=N          the particle count: FMI 3's structural parameter, set in Configuration Mode (fmi3SetUInt64);
//                            FMI 2's Integer parameter, set before initialization
//     --out REF,REF,...      the Real/Float64 outputs printed
//     --steps H,H,...        the communication step sizes, in order
//     --start T              the start time (default 0)
//     --null-logger          no logger at all (FMI 2: a null logger in the callbacks; FMI 3: a null callback)
//     --reset-and-repeat     after Terminate, Reset and run the same sequence again (its rows printed too)
//     --no-terminate         free the instance without Terminate
// Written for this project against fmu/fmi2_api.hpp and fmu/fmi3_api.hpp.
#include <dlfcn.h>

#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "fmi2_api.hpp"
#include "fmi3_api.hpp"

namespace {

int problems = 0;   // messages of warning or worse, and calls that did not return OK

void complain(const char* what) {
  std::fprintf(stderr, "%s\n", what);
  ++problems;
}

// FMI 2's logger takes a printf format.
void fmi2_logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category, fmi2String message, ...) {
  if (env != &problems) complain("fmi2 logger: componentEnvironment is not the one passed to fmi2Instantiate");
  char text[4096];
  va_list args;
  va_start(args, message);
  std::vsnprintf(text, sizeof text, message, args);
  va_end(args);
  if (status != fmi2OK) {
    std::fprintf(stderr, "[%s] status %d %s: %s\n", instance, int(status), category, text);
    ++problems;
  }
}

void fmi3_logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
  if (env != &problems) complain("fmi3 logger: instanceEnvironment is not the one passed to fmi3InstantiateCoSimulation");
  if (status != fmi3OK) {
    std::fprintf(stderr, "status %d %s: %s\n", int(status), category, message);
    ++problems;
  }
}

template <class F>
F symbol(void* library, const char* name) {
  void* f = dlsym(library, name);
  if (!f) {
    std::fprintf(stderr, "the library exports no %s\n", name);
    std::exit(2);
  }
  return reinterpret_cast<F>(f);
}

void check(int status, const char* call) {
  if (status != 0) {
    std::fprintf(stderr, "%s returned status %d\n", call, status);
    ++problems;
  }
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= text.size(); ++i)
    if (i == text.size() || text[i] == sep) out.push_back(text.substr(start, i - start)), start = i + 1;
  return out;
}

void print_row(double t, const std::vector<double>& values) {
  std::printf("%a", t);
  for (double v : values) std::printf(",%a", v);
  std::printf("\n");
}

struct Plan {
  int version = 2;
  std::string library, resources, token;
  std::vector<std::pair<fmi3ValueReference, double>> sets;
  std::vector<std::pair<fmi3ValueReference, fmi3UInt64>> counts;
  std::vector<fmi3ValueReference> outputs;
  std::vector<double> steps;
  double start = 0;
  bool null_logger = false, reset_and_repeat = false, no_terminate = false;
};

void run_fmi2(const Plan& plan, void* lib) {
  auto instantiate = symbol<fmi2Component (*)(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions*,
                                              fmi2Boolean, fmi2Boolean)>(lib, "fmi2Instantiate");
  auto debug = symbol<fmi2Status (*)(fmi2Component, fmi2Boolean, size_t, const fmi2String[])>(lib, "fmi2SetDebugLogging");
  auto setup = symbol<fmi2Status (*)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real)>(lib, "fmi2SetupExperiment");
  auto enter = symbol<fmi2Status (*)(fmi2Component)>(lib, "fmi2EnterInitializationMode");
  auto exit = symbol<fmi2Status (*)(fmi2Component)>(lib, "fmi2ExitInitializationMode");
  auto set_real = symbol<fmi2Status (*)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Real[])>(lib, "fmi2SetReal");
  auto set_integer = symbol<fmi2Status (*)(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Integer[])>(
      lib, "fmi2SetInteger");
  auto get_real = symbol<fmi2Status (*)(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[])>(lib, "fmi2GetReal");
  auto do_step = symbol<fmi2Status (*)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean)>(lib, "fmi2DoStep");
  auto real_status = symbol<fmi2Status (*)(fmi2Component, fmi2StatusKind, fmi2Real*)>(lib, "fmi2GetRealStatus");
  auto terminate = symbol<fmi2Status (*)(fmi2Component)>(lib, "fmi2Terminate");
  auto reset = symbol<fmi2Status (*)(fmi2Component)>(lib, "fmi2Reset");
  auto free_instance = symbol<void (*)(fmi2Component)>(lib, "fmi2FreeInstance");

  fmi2CallbackFunctions callbacks{plan.null_logger ? nullptr : fmi2_logger, std::calloc, std::free, nullptr, &problems};
  fmi2Component c = instantiate("strict host", fmi2CoSimulation, plan.token.c_str(), plan.resources.c_str(), &callbacks, 0, 1);
  if (!c) {
    std::fprintf(stderr, "fmi2Instantiate returned NULL\n");
    std::exit(1);
  }
  check(debug(c, 1, 0, nullptr), "fmi2SetDebugLogging");
  std::vector<double> values(plan.outputs.size());
  double stop = plan.start;
  for (double h : plan.steps) stop += h;
  for (int run = 0; run < (plan.reset_and_repeat ? 2 : 1); ++run) {
    check(setup(c, 1, 1e-6, plan.start, 1, stop), "fmi2SetupExperiment");
    for (const auto& [ref, count] : plan.counts) {
      const fmi2Integer value = fmi2Integer(count);
      check(set_integer(c, &ref, 1, &value), "fmi2SetInteger");
    }
    for (const auto& [ref, value] : plan.sets) check(set_real(c, &ref, 1, &value), "fmi2SetReal");
    check(enter(c), "fmi2EnterInitializationMode");
    check(get_real(c, plan.outputs.data(), plan.outputs.size(), values.data()), "fmi2GetReal (initialization mode)");
    print_row(plan.start, values);
    check(exit(c), "fmi2ExitInitializationMode");
    double t = plan.start;
    for (double h : plan.steps) {
      check(do_step(c, t, h, 1), "fmi2DoStep");
      t += h;
      check(get_real(c, plan.outputs.data(), plan.outputs.size(), values.data()), "fmi2GetReal");
      print_row(t, values);
      double reached = 0;
      check(real_status(c, fmi2LastSuccessfulTime, &reached), "fmi2GetRealStatus");
      if (reached != t) complain("fmi2LastSuccessfulTime is not the communication point reached");
    }
    if (plan.no_terminate) break;
    check(terminate(c), "fmi2Terminate");
    if (plan.reset_and_repeat && run == 0) check(reset(c), "fmi2Reset");
  }
  free_instance(c);
}

void run_fmi3(const Plan& plan, void* lib) {
  auto instantiate = symbol<fmi3Instance (*)(fmi3String, fmi3String, fmi3String, fmi3Boolean, fmi3Boolean, fmi3Boolean, fmi3Boolean,
                                             const fmi3ValueReference[], size_t, fmi3InstanceEnvironment, fmi3LogMessageCallback,
                                             fmi3IntermediateUpdateCallback)>(lib, "fmi3InstantiateCoSimulation");
  auto debug = symbol<fmi3Status (*)(fmi3Instance, fmi3Boolean, size_t, const fmi3String[])>(lib, "fmi3SetDebugLogging");
  auto enter_config = symbol<fmi3Status (*)(fmi3Instance)>(lib, "fmi3EnterConfigurationMode");
  auto exit_config = symbol<fmi3Status (*)(fmi3Instance)>(lib, "fmi3ExitConfigurationMode");
  auto enter = symbol<fmi3Status (*)(fmi3Instance, fmi3Boolean, fmi3Float64, fmi3Float64, fmi3Boolean, fmi3Float64)>(
      lib, "fmi3EnterInitializationMode");
  auto exit = symbol<fmi3Status (*)(fmi3Instance)>(lib, "fmi3ExitInitializationMode");
  auto set_float = symbol<fmi3Status (*)(fmi3Instance, const fmi3ValueReference[], size_t, const fmi3Float64[], size_t)>(
      lib, "fmi3SetFloat64");
  auto set_uint = symbol<fmi3Status (*)(fmi3Instance, const fmi3ValueReference[], size_t, const fmi3UInt64[], size_t)>(
      lib, "fmi3SetUInt64");
  auto get_float = symbol<fmi3Status (*)(fmi3Instance, const fmi3ValueReference[], size_t, fmi3Float64[], size_t)>(
      lib, "fmi3GetFloat64");
  auto do_step = symbol<fmi3Status (*)(fmi3Instance, fmi3Float64, fmi3Float64, fmi3Boolean, fmi3Boolean*, fmi3Boolean*, fmi3Boolean*,
                                       fmi3Float64*)>(lib, "fmi3DoStep");
  auto terminate = symbol<fmi3Status (*)(fmi3Instance)>(lib, "fmi3Terminate");
  auto reset = symbol<fmi3Status (*)(fmi3Instance)>(lib, "fmi3Reset");
  auto free_instance = symbol<void (*)(fmi3Instance)>(lib, "fmi3FreeInstance");

  fmi3Instance c = instantiate("strict host", plan.token.c_str(), plan.resources.c_str(), false, true, false, false, nullptr, 0,
                               &problems, plan.null_logger ? nullptr : fmi3_logger, nullptr);
  if (!c) {
    std::fprintf(stderr, "fmi3InstantiateCoSimulation returned NULL\n");
    std::exit(1);
  }
  check(debug(c, true, 0, nullptr), "fmi3SetDebugLogging");
  std::vector<double> values(plan.outputs.size());
  double stop = plan.start;
  for (double h : plan.steps) stop += h;
  for (int run = 0; run < (plan.reset_and_repeat ? 2 : 1); ++run) {
    if (!plan.counts.empty()) {
      check(enter_config(c), "fmi3EnterConfigurationMode");
      for (const auto& [ref, value] : plan.counts) check(set_uint(c, &ref, 1, &value, 1), "fmi3SetUInt64");
      check(exit_config(c), "fmi3ExitConfigurationMode");
    }
    for (const auto& [ref, value] : plan.sets) check(set_float(c, &ref, 1, &value, 1), "fmi3SetFloat64");
    check(enter(c, true, 1e-6, plan.start, true, stop), "fmi3EnterInitializationMode");
    check(get_float(c, plan.outputs.data(), plan.outputs.size(), values.data(), values.size()), "fmi3GetFloat64 (initialization mode)");
    print_row(plan.start, values);
    check(exit(c), "fmi3ExitInitializationMode");
    double t = plan.start;
    for (double h : plan.steps) {
      fmi3Boolean event = true, stop_now = true, early = true;
      fmi3Float64 reached = -1;
      check(do_step(c, t, h, true, &event, &stop_now, &early, &reached), "fmi3DoStep");
      if (event || stop_now || early) complain("fmi3DoStep asked for event handling, termination or returned early");
      t += h;
      if (reached != t) complain("fmi3DoStep's lastSuccessfulTime is not the communication point reached");
      check(get_float(c, plan.outputs.data(), plan.outputs.size(), values.data(), values.size()), "fmi3GetFloat64");
      print_row(t, values);
    }
    if (plan.no_terminate) break;
    check(terminate(c), "fmi3Terminate");
    if (plan.reset_and_repeat && run == 0) check(reset(c), "fmi3Reset");
  }
  free_instance(c);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: strict_host VERSION LIBRARY RESOURCES TOKEN [options]\n");
    return 2;
  }
  Plan plan;
  plan.version = std::atoi(argv[1]);
  plan.library = argv[2], plan.resources = argv[3], plan.token = argv[4];
  for (int i = 5; i < argc; ++i) {
    const std::string option = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) std::fprintf(stderr, "%s needs a value\n", option.c_str()), std::exit(2);
      return argv[++i];
    };
    if (option == "--set" || option == "--count") {
      const auto parts = split(next(), '=');
      if (option == "--set") plan.sets.emplace_back(std::stoul(parts[0]), std::stod(parts[1]));
      else plan.counts.emplace_back(std::stoul(parts[0]), std::stoull(parts[1]));
    } else if (option == "--out") {
      for (const auto& r : split(next(), ',')) plan.outputs.push_back(std::stoul(r));
    } else if (option == "--steps") {
      for (const auto& h : split(next(), ',')) plan.steps.push_back(std::stod(h));
    } else if (option == "--start") {
      plan.start = std::stod(next());
    } else if (option == "--null-logger") {
      plan.null_logger = true;
    } else if (option == "--reset-and-repeat") {
      plan.reset_and_repeat = true;
    } else if (option == "--no-terminate") {
      plan.no_terminate = true;
    } else {
      std::fprintf(stderr, "unknown option %s\n", option.c_str());
      return 2;
    }
  }
  void* lib = dlopen(plan.library.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!lib) {
    std::fprintf(stderr, "dlopen: %s\n", dlerror());
    return 2;
  }
  plan.version == 3 ? run_fmi3(plan, lib) : run_fmi2(plan, lib);
  dlclose(lib);
  return problems == 0 ? 0 : 1;
}
