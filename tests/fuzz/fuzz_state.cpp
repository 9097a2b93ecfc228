// libFuzzer target: a simulation's saved state (Simulation::restore_state, what a checkpoint and an FMU state
// hold) with arbitrary bytes. The first input byte picks one of a few small scenes (each with other modules: a
// cell, gravity, friction, rolling, the collision log); the rest is the state without its check sum, which the
// harness appends, so that the fuzzer reaches the loaders behind it (the sum stops corruption, not a crafted state).
// A state restore_state takes must step (or fail with a SimulationError) without a sanitizer report; one it refuses
// must leave the simulation unchanged, as it promises.
//
// GRAINS_FUZZ_SEEDS=DIR: write each scene's state after a few steps there, as seeds, and stop.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/byte_stream.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"

namespace {

struct Case {
  std::unique_ptr<grains::Simulation> sim;
  std::vector<std::byte> pristine;   // its state after a few steps, restored after each input
};
std::vector<Case> cases;

[[noreturn]] void finding(const std::string& what) {
  fprintf(stderr, "FINDING: %s\n", what.c_str());
  std::abort();
}

void add(const std::string& model, const std::vector<std::string>& overrides) {
  const std::filesystem::path file = std::filesystem::path(GRAINS_MODELS_DIR) / (model + ".toml");
  try {
    auto sim = grains::Simulation::create(grains::Scene::from_file(file, overrides));
    sim->step_n(5);
    auto state = sim->save_state();
    cases.push_back({std::move(sim), std::move(state)});
  } catch (const std::exception& e) {
    finding("a seed scene did not build: " + model + ": " + e.what());
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  add("collision", {"run.threads=1"});
  add("gas-friction", {"run.threads=1", "particles.count=27"});
  add("aggregation", {"run.threads=1", "particles.count=20", "analysis.collision_log=true"});
  add("consolidation", {"run.threads=1", "particles.count=16"});
  add("consolidation-rr-3d", {"run.threads=1", "particles.count=27"});
  if (const char* dir = std::getenv("GRAINS_FUZZ_SEEDS")) {
    for (std::size_t k = 0; k < cases.size(); ++k) {
      std::ofstream out(std::filesystem::path(dir) / ("state-" + std::to_string(k)), std::ios::binary);
      out.put(char(k));
      out.write(reinterpret_cast<const char*>(cases[k].pristine.data()), std::streamsize(cases[k].pristine.size() - 8));
    }
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  Case& c = cases[data[0] % cases.size()];
  const auto body = std::as_bytes(std::span(data + 1, size - 1));
  std::vector<std::byte> state(body.begin(), body.end());
  const std::uint64_t sum = grains::check_sum(body);
  const auto* sum_bytes = reinterpret_cast<const std::byte*>(&sum);
  state.insert(state.end(), sum_bytes, sum_bytes + sizeof sum);
  try {
    c.sim->restore_state(state);
  } catch (const grains::SimulationError&) {
    if (const auto now = c.sim->save_state(); now != c.pristine) {
      std::size_t at = 0;
      while (at < now.size() && at < c.pristine.size() && now[at] == c.pristine[at]) ++at;
      if (const char* dump = std::getenv("GRAINS_FUZZ_DUMP")) {   // both states, for a closer look
        std::ofstream(std::string(dump) + ".before", std::ios::binary).write(reinterpret_cast<const char*>(c.pristine.data()), std::streamsize(c.pristine.size()));
        std::ofstream(std::string(dump) + ".after", std::ios::binary).write(reinterpret_cast<const char*>(now.data()), std::streamsize(now.size()));
      }
      std::string around;   // the 8-byte words there, as doubles, before and now
      for (std::size_t k = at - at % 8; k < at - at % 8 + 32 && k + 8 <= std::min(now.size(), c.pristine.size()); k += 8) {
        double a, b;
        std::memcpy(&a, c.pristine.data() + k, 8), std::memcpy(&b, now.data() + k, 8);
        around += " " + std::to_string(a) + "->" + std::to_string(b);
      }
      finding("a refused state changed the simulation: its state differs from byte " + std::to_string(at) + " of " +
              std::to_string(c.pristine.size()) + " (now " + std::to_string(now.size()) + "):" + around);
    }
    return 0;
  } catch (const std::exception& e) {
    finding(std::string("restore_state threw another exception than SimulationError: ") + e.what());
  }
  try {
    c.sim->step_n(2);
    (void)c.sim->particles();
    for (std::size_t i = 0; i < c.sim->variables().size(); ++i) (void)c.sim->get(i);
  } catch (const grains::SimulationError&) {
  } catch (const std::exception& e) {
    finding(std::string("a step after a restored state threw another exception than SimulationError: ") + e.what());
  }
  c.sim->restore_state(c.pristine);
  return 0;
}
