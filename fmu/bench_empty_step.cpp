// Benchmark (not a test): the FMU's own cost of an empty fmi3DoStep (step size 0) and of an
// fmi3DoStep of one internal step, called from C++ through dlopen, as a compiled host would.
// Usage: grains_fmu_bench EXTRACTED_FMU_DIR MODEL_IDENTIFIER [calls]
#include <dlfcn.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "fmi3_api.hpp"

namespace {
void log_message(fmi3InstanceEnvironment, fmi3Status, fmi3String category, fmi3String message) {
  std::fprintf(stderr, "[%s] %s\n", category, message);
}
template <class F> F symbol(void* lib, const char* name) {
  void* p = dlsym(lib, name);
  if (!p) {
    std::fprintf(stderr, "missing symbol %s\n", name);
    std::exit(1);
  }
  return reinterpret_cast<F>(p);
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: grains_fmu_bench EXTRACTED_FMU_DIR MODEL_IDENTIFIER [calls]\n"
                         "  EXTRACTED_FMU_DIR: an unpacked FMI 3 unit, e.g. build/fmu/stage/collision/fmi3\n");
    return 2;
  }
  const std::string dir = argv[1], id = argv[2];
  long calls = 1000000;
  if (argc > 3) {
    char* end = nullptr;
    calls = std::strtol(argv[3], &end, 10);
    if (end == argv[3] || *end != '\0' || calls < 1) {
      std::fprintf(stderr, "grains_fmu_bench: calls = '%s' is not allowed: a whole number >= 1\n", argv[3]);
      return 2;
    }
  }
  // The instantiation token, as a host reads it from the model description.
  std::ifstream description(dir + "/modelDescription.xml");
  const std::string xml((std::istreambuf_iterator<char>(description)), std::istreambuf_iterator<char>());
  const std::string key = "instantiationToken=\"";
  const std::size_t at = xml.find(key), from = at + key.size(), to = at == std::string::npos ? at : xml.find('"', from);
  if (to == std::string::npos) {
    std::fprintf(stderr, "grains_fmu_bench: no instantiationToken in %s/modelDescription.xml\n", dir.c_str());
    return 2;
  }
  const std::string token = xml.substr(from, to - from);
  void* lib = dlopen((dir + "/binaries/x86_64-linux/" + id + ".so").c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!lib) {
    std::fprintf(stderr, "%s\n", dlerror());
    return 1;
  }
  using Instantiate = fmi3Instance (*)(fmi3String, fmi3String, fmi3String, fmi3Boolean, fmi3Boolean, fmi3Boolean, fmi3Boolean,
                                       const fmi3ValueReference[], size_t, fmi3InstanceEnvironment, fmi3LogMessageCallback,
                                       fmi3IntermediateUpdateCallback);
  using EnterInit = fmi3Status (*)(fmi3Instance, fmi3Boolean, fmi3Float64, fmi3Float64, fmi3Boolean, fmi3Float64);
  using Simple = fmi3Status (*)(fmi3Instance);
  using DoStep = fmi3Status (*)(fmi3Instance, fmi3Float64, fmi3Float64, fmi3Boolean, fmi3Boolean*, fmi3Boolean*, fmi3Boolean*,
                                fmi3Float64*);
  using GetFloat64 = fmi3Status (*)(fmi3Instance, const fmi3ValueReference[], size_t, fmi3Float64[], size_t);
  auto instantiate = symbol<Instantiate>(lib, "fmi3InstantiateCoSimulation");
  auto enter_init = symbol<EnterInit>(lib, "fmi3EnterInitializationMode");
  auto exit_init = symbol<Simple>(lib, "fmi3ExitInitializationMode");
  auto do_step = symbol<DoStep>(lib, "fmi3DoStep");
  auto free_instance = symbol<void (*)(fmi3Instance)>(lib, "fmi3FreeInstance");
  (void)symbol<GetFloat64>(lib, "fmi3GetFloat64");

  fmi3Instance c = instantiate("bench", token.c_str(), (dir + "/resources/").c_str(), false, false, false, false, nullptr, 0, nullptr,
                               log_message, nullptr);
  if (!c || enter_init(c, false, 0, 0, false, 0) != fmi3OK || exit_init(c) != fmi3OK) return 1;
  fmi3Boolean event, terminate, early;
  fmi3Float64 reached;
  const auto t0 = std::chrono::steady_clock::now();
  for (long k = 0; k < calls; ++k) do_step(c, 0.0, 0.0, false, &event, &terminate, &early, &reached);
  const double empty = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / double(calls);
  std::printf("empty fmi3DoStep (step size 0), %ld calls: %.3g us per call\n", calls, empty * 1e6);
  free_instance(c);
  dlclose(lib);
  return 0;
}
