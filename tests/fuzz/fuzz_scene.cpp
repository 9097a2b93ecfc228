// libFuzzer target: a scene's TOML text, with --set overrides, through the parser and the schema's checks.
// Lines "#set key=value" of the input (TOML comments, which the parser skips) are the overrides, so one input
// exercises both paths. Bad input must end in a SceneError; anything else (a crash, a sanitizer report, another
// exception, a hang) is a finding. A scene that passes must also pass again as its own resolved text, as a
// checkpoint stores it (`grains resume` reads it back so).
//
// Built as fuzz_scene_build too (GRAINS_FUZZ_BUILD): a valid scene of a few particles is then built and stepped,
// so the set-up's own checks (Simulation::create) see the fuzzer's values.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "io/scene.hpp"
#ifdef GRAINS_FUZZ_BUILD
#include "core/simulation.hpp"
#endif

namespace {

std::vector<std::string> overrides_in(std::string_view text) {
  std::vector<std::string> out;
  for (std::size_t start = 0; start < text.size();) {
    auto end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(start, end - start);
    if (line.starts_with("#set ")) out.emplace_back(line.substr(5));
    start = end + 1;
  }
  return out;
}

[[noreturn]] void finding(const char* what, const std::string& detail) {
  fprintf(stderr, "FINDING: %s: %s\n", what, detail.c_str());
  std::abort();
}

#ifdef GRAINS_FUZZ_BUILD
// Small scenes only: a large count is slow, not wrong. A file layout reads a path the fuzzer names (fuzz_particle_file
// covers that reader).
bool small_enough(const grains::Scene& s) {
  if (s.text("particles.layout") == "file") return false;
  if (s.has("particles.count") && s.integer("particles.count") > 64) return false;
  if (s.has("run.threads") && s.integer("run.threads") > 2) return false;
  return true;
}
#endif

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::string resolved;
  try {
    const grains::Scene s = grains::Scene::from_string(text, "fuzz.toml", overrides_in(text), "/nonexistent");
    s.validate();
    (void)s.superseded_keys();
    resolved = s.resolved_toml();
#ifdef GRAINS_FUZZ_BUILD
    if (small_enough(s)) {
      try {
        auto sim = grains::Simulation::create(s);
        sim->step_n(3);
        (void)sim->particles();
      } catch (const grains::SceneError&) {
      } catch (const grains::SimulationError&) {
      }
    }
#endif
  } catch (const grains::SceneError& e) {
    if (std::string_view(e.what()).empty()) finding("empty SceneError message", "");
    return 0;
  } catch (const std::exception& e) {
    finding("an exception other than SceneError", e.what());
  }
  // The resolved scene (as a checkpoint stores it) reads back and passes.
  try {
    grains::Scene again = grains::Scene::from_string(resolved, "resolved.toml", {}, "/nonexistent");
    again.accept_unread_keys();
    again.validate();
  } catch (const std::exception& e) {
    finding("the resolved scene does not read back", std::string(e.what()) + "\n--- resolved:\n" + resolved);
  }
  return 0;
}
