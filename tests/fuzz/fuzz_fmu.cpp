// libFuzzer target: a host's FMI 2 calls in any order with any values, into the FMU's own sources linked in.
// Each input is a call sequence on a fresh instance of one of two small scenes: set-up, initialization, steps,
// setters with NaN, infinities, huge and negative values and references out of range, states saved, restored,
// serialized and deserialized, the serialized bytes corrupted at a place the input picks (with their two check sums
// made right again, or not). The FMU must never crash the host; and every call that returns fmi2Error must have
// said why through the host's logger first.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <fuzzer/FuzzedDataProvider.h>

#include "core/byte_stream.hpp"
#include "core/simulation.hpp"
#include "fmi2_api.hpp"
#include "io/scene.hpp"
#include "model_variables.hpp"

extern "C" {
fmi2Component fmi2Instantiate(fmi2String, fmi2Type, fmi2String, fmi2String, const fmi2CallbackFunctions*, fmi2Boolean, fmi2Boolean);
void fmi2FreeInstance(fmi2Component);
fmi2Status fmi2SetupExperiment(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
fmi2Status fmi2EnterInitializationMode(fmi2Component);
fmi2Status fmi2ExitInitializationMode(fmi2Component);
fmi2Status fmi2Terminate(fmi2Component);
fmi2Status fmi2Reset(fmi2Component);
fmi2Status fmi2GetReal(fmi2Component, const fmi2ValueReference[], size_t, fmi2Real[]);
fmi2Status fmi2GetInteger(fmi2Component, const fmi2ValueReference[], size_t, fmi2Integer[]);
fmi2Status fmi2GetBoolean(fmi2Component, const fmi2ValueReference[], size_t, fmi2Boolean[]);
fmi2Status fmi2SetReal(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Real[]);
fmi2Status fmi2SetInteger(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Integer[]);
fmi2Status fmi2SetBoolean(fmi2Component, const fmi2ValueReference[], size_t, const fmi2Boolean[]);
fmi2Status fmi2SetString(fmi2Component, const fmi2ValueReference[], size_t, const fmi2String[]);
fmi2Status fmi2GetFMUstate(fmi2Component, fmi2FMUstate*);
fmi2Status fmi2SetFMUstate(fmi2Component, fmi2FMUstate);
fmi2Status fmi2FreeFMUstate(fmi2Component, fmi2FMUstate*);
fmi2Status fmi2SerializedFMUstateSize(fmi2Component, fmi2FMUstate, size_t*);
fmi2Status fmi2SerializeFMUstate(fmi2Component, fmi2FMUstate, fmi2Byte[], size_t);
fmi2Status fmi2DeSerializeFMUstate(fmi2Component, const fmi2Byte[], size_t, fmi2FMUstate*);
fmi2Status fmi2DoStep(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);
fmi2Status fmi2GetRealStatus(fmi2Component, const fmi2StatusKind, fmi2Real*);
}

namespace {

struct Model {
  std::string resources, token;
  std::size_t variables = 0;
};
std::vector<Model> models;
int errors_logged = 0;   // messages of status fmi2Error or fmi2Fatal since the last call
std::string last_error;

void logger(fmi2ComponentEnvironment, fmi2String, fmi2Status status, fmi2String, fmi2String message, ...) {
  if (!message) std::abort();
  if (status >= fmi2Error) ++errors_logged, last_error = message;
}
const fmi2CallbackFunctions callbacks{logger, nullptr, nullptr, nullptr, nullptr};

[[noreturn]] void finding(const std::string& what) {
  fprintf(stderr, "FINDING: %s\n", what.c_str());
  std::abort();
}

// A fmi2Error (or worse) without a message of that status: the host is not told why.
fmi2Status checked(fmi2Status s, const char* call) {
  if (s >= fmi2Error && errors_logged == 0) finding(std::string(call) + " returned an error without logging one");
  errors_logged = 0;
  return s;
}

// A scene packaged as an FMU would be: its resolved text as resources/scene.toml, the token of its variable table.
void add(const std::string& model, const std::vector<std::string>& overrides) {
  const auto given = grains::Scene::from_file(std::filesystem::path(GRAINS_MODELS_DIR) / (model + ".toml"), overrides);
  const auto dir = std::filesystem::temp_directory_path() / ("grains-fuzz-fmu-" + std::to_string(getpid())) / model;
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "scene.toml") << given.resolved_toml();
  const auto scene = grains::Scene::from_file(dir / "scene.toml");   // as the FMU reads it
  const auto sim = grains::Simulation::create(scene);
  const auto table = grains::fmu::describe_model(scene, *sim);
  models.push_back({dir.string(), grains::fmu::instantiation_token(table), table.variables.size()});
}

double any_real(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange(0, 9)) {
    case 0: return std::numeric_limits<double>::quiet_NaN();
    case 1: return std::numeric_limits<double>::infinity();
    case 2: return -std::numeric_limits<double>::infinity();
    case 3: return 1e308;
    case 4: return -1.0;
    case 5: return 0.0;
    case 6: return std::numeric_limits<double>::denorm_min();
    case 7: return in.ConsumeFloatingPointInRange(-10.0, 10.0);
    default: return in.ConsumeFloatingPoint<double>();
  }
}

// Serialized bytes corrupted at the input's places; with both check sums (the FMU's over all, the simulation's over
// its part) recomputed where the input asks, so the corruption reaches the readers behind them.
void corrupt(FuzzedDataProvider& in, std::vector<char>& bytes) {
  const int edits = in.ConsumeIntegralInRange(0, 4);
  for (int k = 0; k < edits && !bytes.empty(); ++k) {
    const auto at = in.ConsumeIntegralInRange<std::size_t>(0, bytes.size() - 1);
    switch (in.ConsumeIntegralInRange(0, 3)) {
      case 0: bytes[at] = char(in.ConsumeIntegral<std::uint8_t>()); break;
      case 1: bytes.resize(at); break;
      case 2: bytes.insert(bytes.begin() + std::ptrdiff_t(at), in.ConsumeIntegralInRange(1, 16), char(in.ConsumeIntegral<std::uint8_t>())); break;
      default: {   // a 64-bit word (a count, an index, a time) replaced
        std::uint64_t word = in.ConsumeIntegral<std::uint64_t>();
        if (at + 8 <= bytes.size()) std::memcpy(bytes.data() + at, &word, 8);
      }
    }
  }
  if (!in.ConsumeBool() || bytes.size() < 32 + 8 + 16) return;
  auto fix = [&](std::size_t first, std::size_t last) {   // the sum of [first, last) written at last
    const auto sum = grains::check_sum(std::as_bytes(std::span(bytes.data() + first, last - first)));
    std::memcpy(bytes.data() + last, &sum, 8);
  };
  fix(32, bytes.size() - 16);
  fix(0, bytes.size() - 8);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  add("collision", {"run.threads=1"});
  add("consolidation", {"run.threads=1", "particles.count=16"});
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const Model& m = models[in.ConsumeIntegralInRange<std::size_t>(0, models.size() - 1)];
  errors_logged = 0;
  fmi2Component c = fmi2Instantiate("fuzz", fmi2CoSimulation, m.token.c_str(), m.resources.c_str(), &callbacks, 0, in.ConsumeBool());
  if (!c) finding("the packaged scene did not instantiate: " + last_error);
  std::vector<fmi2FMUstate> states;
  std::vector<std::vector<char>> serialized;
  double now = 0;
  for (int call = 0; call < 24 && in.remaining_bytes() > 0; ++call) {
    const auto vr = in.ConsumeIntegralInRange<fmi2ValueReference>(0, fmi2ValueReference(m.variables + 2));
    switch (in.ConsumeIntegralInRange(0, 17)) {
      case 0: checked(fmi2SetupExperiment(c, 0, 0, now = any_real(in), 0, 0), "fmi2SetupExperiment"); break;
      case 1: checked(fmi2EnterInitializationMode(c), "fmi2EnterInitializationMode"); break;
      case 2: checked(fmi2ExitInitializationMode(c), "fmi2ExitInitializationMode"); break;
      case 3: {   // mostly a step from where the FMU is, of a few of its time steps
        const double h = in.ConsumeBool() ? any_real(in) : in.ConsumeFloatingPointInRange(0.0, 0.05);
        const double t = in.ConsumeBool() ? any_real(in) : now;
        if (checked(fmi2DoStep(c, t, h, 1), "fmi2DoStep") <= fmi2Warning) now = t + h;
        break;
      }
      case 4: {
        const double v = any_real(in);
        checked(fmi2SetReal(c, &vr, 1, &v), "fmi2SetReal");
        break;
      }
      case 5: {
        const fmi2Integer v = in.ConsumeIntegral<fmi2Integer>();
        checked(fmi2SetInteger(c, &vr, 1, &v), "fmi2SetInteger");
        break;
      }
      case 6: {
        const fmi2Boolean v = in.ConsumeIntegral<fmi2Boolean>();
        checked(fmi2SetBoolean(c, &vr, 1, &v), "fmi2SetBoolean");
        break;
      }
      case 7: {
        const std::string text = in.ConsumeBool() ? std::string(100000, 'x') : in.ConsumeRandomLengthString(64);
        const fmi2String v = text.c_str();
        checked(fmi2SetString(c, &vr, 1, &v), "fmi2SetString");
        break;
      }
      case 8: {
        fmi2Real r;
        fmi2Integer i;
        fmi2Boolean b;
        checked(fmi2GetReal(c, &vr, 1, &r), "fmi2GetReal");
        checked(fmi2GetInteger(c, &vr, 1, &i), "fmi2GetInteger");
        checked(fmi2GetBoolean(c, &vr, 1, &b), "fmi2GetBoolean");
        break;
      }
      case 9: {   // every real at once, as a host's output read
        std::vector<fmi2ValueReference> all(m.variables);
        for (std::size_t k = 0; k < all.size(); ++k) all[k] = fmi2ValueReference(k);
        std::vector<fmi2Real> values(all.size());
        checked(fmi2GetReal(c, all.data(), all.size(), values.data()), "fmi2GetReal");
        break;
      }
      case 10: {
        fmi2FMUstate s = nullptr;
        if (checked(fmi2GetFMUstate(c, &s), "fmi2GetFMUstate") == fmi2OK) states.push_back(s);
        break;
      }
      case 11:
        if (!states.empty())
          checked(fmi2SetFMUstate(c, states[in.ConsumeIntegralInRange<std::size_t>(0, states.size() - 1)]), "fmi2SetFMUstate");
        break;
      case 12:
        if (!states.empty()) {
          const auto k = in.ConsumeIntegralInRange<std::size_t>(0, states.size() - 1);
          checked(fmi2FreeFMUstate(c, &states[k]), "fmi2FreeFMUstate");
          states.erase(states.begin() + std::ptrdiff_t(k));
        }
        break;
      case 13:
        if (!states.empty()) {
          fmi2FMUstate s = states[in.ConsumeIntegralInRange<std::size_t>(0, states.size() - 1)];
          std::size_t n = 0;
          if (checked(fmi2SerializedFMUstateSize(c, s, &n), "fmi2SerializedFMUstateSize") != fmi2OK) break;
          std::vector<char> bytes(n);
          if (checked(fmi2SerializeFMUstate(c, s, bytes.data(), n), "fmi2SerializeFMUstate") == fmi2OK) serialized.push_back(bytes);
        }
        break;
      case 14: {   // serialized bytes (corrupted, or the input's own) back into a state, and that state set
        std::vector<char> bytes;
        if (!serialized.empty() && in.ConsumeBool()) {
          bytes = serialized[in.ConsumeIntegralInRange<std::size_t>(0, serialized.size() - 1)];
          corrupt(in, bytes);
        } else {
          const std::string raw = in.ConsumeRandomLengthString(256);
          bytes.assign(raw.begin(), raw.end());
        }
        fmi2FMUstate s = nullptr;
        if (checked(fmi2DeSerializeFMUstate(c, bytes.data(), bytes.size(), &s), "fmi2DeSerializeFMUstate") == fmi2OK) {
          states.push_back(s);
          checked(fmi2SetFMUstate(c, s), "fmi2SetFMUstate");
        }
        break;
      }
      case 15: checked(fmi2Reset(c), "fmi2Reset"), now = 0; break;
      case 16: checked(fmi2Terminate(c), "fmi2Terminate"); break;
      default: {
        fmi2Real t;
        checked(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t), "fmi2GetRealStatus");
      }
    }
  }
  for (auto& s : states) fmi2FreeFMUstate(c, &s);
  fmi2FreeInstance(c);
  return 0;
}
