// Build-time generator: loads a packaged scene, builds its Simulation, and writes from the one
// variable table everything an FMU carries besides the binary:
//   OUT/fmi2/modelDescription.xml, OUT/fmi3/modelDescription.xml, OUT/documentation/index.html,
//   OUT/extra/org.fmi-standard.fmi-ls-ref/ (reference results: <name>_ref.csv, <name>_ref.opt, manifest),
//   OUT/resources.txt (the files besides the scene that resources/ must hold: its particles.file, relative to it).
// Usage: grains_fmu_describe SCENE.toml MODEL_IDENTIFIER OUT_DIR VERSION
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "model_description.hpp"
#include "model_variables.hpp"
#include "protocols/initial_state.hpp"
#include "protocols/run_length.hpp"

namespace fs = std::filesystem;
using namespace grains;
using namespace grains::fmu;

namespace {

void write(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

// Reference results in the FMI cross-check shape: the packaged scene with default parameters,
// driven exactly as a host does (Simulation::step per communication step), every scalar output.
void write_reference(const Scene& scene, const ModelTable& table, const ModelInfo& info, const fs::path& dir) {
  auto sim = Simulation::create(scene);
  const double step = 5 * sim->dt();   // 20 communication steps of 5 dt: quick to build and to check
  const int points = int(std::min(20.0, std::floor(info.stop_time / step + 1e-9)));
  std::string csv = "\"time\"";
  std::vector<std::size_t> columns;
  for (const auto& v : table.variables)   // wall-clock outputs (cvode_seconds) differ in every run: not a reference
    if (v.role == Role::output && !v.name.ends_with("_seconds"))
      csv += fmt::format(",\"{}\"", v.name), columns.push_back(v.sim_index);
  csv += "\n";
  for (int k = 0; k <= points; ++k) {
    if (k > 0) sim->step(step);
    csv += fmt::format("{}", sim->time());
    for (auto c : columns) csv += fmt::format(",{}", sim->get(c));
    csv += "\n";
  }
  write(dir / (info.name + "_ref.csv"), csv);
  write(dir / (info.name + "_ref.opt"),
        fmt::format("StartTime, 0.0\nStopTime, {}\nStepSize, {}\nRelTol, 1e-12\n", points * step, step));
  write(dir / "fmi-ls-manifest.xml",
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<fmiLayeredStandardManifest xmlns:fmi-ls=\"http://fmi-standard.org/fmi-ls-manifest\"\n"
        "  fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-ref\" fmi-ls:fmi-ls-version=\"1.0.0\"\n"
        "  fmi-ls:fmi-ls-description=\"Reference results of this FMU (cross-check layout: CSV of every output and the run options)\"/>\n");
}

// The scene's particle file, as a path relative to the scene that resources/ will hold (empty: none). The FMU reads
// the scene from resources/, and the file beside it; a path that leads out of the scene's folder would not travel.
std::string packaged_particle_file(const Scene& scene) {
  if (!particle_file(scene)) return "";
  const fs::path given = scene.text("particles.file");
  const fs::path inside = given.lexically_normal();
  if (given.is_absolute() || inside.empty() || *inside.begin() == ".." || inside == "scene.toml")
    throw std::runtime_error(fmt::format(
        "particles.file = '{}': an FMU carries its scene's particle file in resources/, so it must be a relative path "
        "inside the scene's folder (and not scene.toml): move the file beside the scene, or list the particles "
        "(particles.layout = \"list\")", given.string()));
  return inside.generic_string();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: grains_fmu_describe SCENE.toml MODEL_IDENTIFIER OUT_DIR VERSION\n";
    return 2;
  }
  try {
    const Scene scene = Scene::from_file(argv[1]);
    auto sim = Simulation::create(scene);
    const ModelTable table = describe_model(scene, *sim);
    ModelInfo info;
    info.name = scene.text("scene.name");
    info.identifier = argv[2];
    info.description = scene.text("scene.description");
    // A cell scene's description tells of `grains consolidate`'s preparation and programme, which the FMU does
    // not run: a host reading it expected an aggregation and a stepwise loading that never came.
    if (scene.boolean("cell.enabled"))
      info.description += ". This FMU runs no preparation or programme (grains consolidate does): it steps the "
                          "scene's initial state at the target pressure the host sets (input cell.pressure)";
    info.version = argv[4];
    // Communication steps of 100 dt, or fewer so that a short run still gives 100 points (the collision:
    // 5 dt, where 100 would sample its whole run 5 times); a whole number of dt either way.
    const std::optional<long> steps = run_steps(scene, *sim);
    info.step_size = double(std::clamp<long>(steps.value_or(10000) / 100, 1, 100)) * sim->dt();
    info.stop_time = steps ? double(*steps) * sim->dt() : 100 * info.step_size;
    const fs::path out = argv[3];
    write(out / "fmi2" / "modelDescription.xml", fmi2_model_description(table, info));
    write(out / "fmi3" / "modelDescription.xml", fmi3_model_description(table, info));
    write(out / "documentation" / "index.html", documentation_html(table, info));
    write_reference(scene, table, info, out / "extra" / "org.fmi-standard.fmi-ls-ref");
    write(out / "resources.txt", packaged_particle_file(scene));
  } catch (const std::exception& e) {
    std::cerr << "grains_fmu_describe: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
