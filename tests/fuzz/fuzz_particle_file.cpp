// libFuzzer target: the rows of a particles.file (layout = "file"), read by a small 2D and 3D scene and stepped.
// The first input byte picks the scene (its dimension, the file's velocities or drawn ones, a periodic or closed box); the
// rest is the file. A bad file must end in a SceneError naming particles.file, the line and what is allowed; a file it
// takes must build and step (or stop with a SimulationError) without a sanitizer report.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"

namespace {

std::filesystem::path folder;

[[noreturn]] void finding(const std::string& what) {
  fprintf(stderr, "FINDING: %s\n", what.c_str());
  std::abort();
}

std::string scene_text(std::uint8_t pick) {
  const int dimension = pick & 1 ? 2 : 3;
  std::string text = "[scene]\ndimension = " + std::to_string(dimension) +
                     "\n[particles]\nlayout = \"file\"\nfile = \"rows.txt\"\n" +
                     (pick & 2 ? "velocity = \"gaussian\"\n" : "") +
                     "[box]\nlengths = " + (dimension == 2 ? "[10.0, 10.0]" : "[10.0, 10.0, 10.0]") + "\n" +
                     (pick & 4 ? "periodic = false\n" : "") +
                     "[contact]\nrestitution = 0.5\nduration = 0.05\n[run]\nthreads = 1\n";
  return text;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  folder = std::filesystem::temp_directory_path() / ("grains-fuzz-file-" + std::to_string(getpid()));
  std::filesystem::create_directories(folder);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  std::ofstream(folder / "rows.txt", std::ios::binary).write(reinterpret_cast<const char*>(data + 1), std::streamsize(size - 1));
  try {
    auto sim = grains::Simulation::create(grains::Scene::from_string(scene_text(data[0]), "fuzz.toml", {}, folder));
    sim->step_n(3);
    (void)sim->particles();
  } catch (const grains::SceneError& e) {
    if (std::string(e.what()).find("particles.") == std::string::npos) finding(std::string("a SceneError naming no particles key: ") + e.what());
  } catch (const grains::SimulationError&) {
  } catch (const std::exception& e) {
    finding(std::string("another exception than SceneError or SimulationError: ") + e.what());
  }
  return 0;
}
