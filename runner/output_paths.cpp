#include "output_paths.hpp"

#include <filesystem>
#include <optional>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "io/scene.hpp"
#include "protocols/initial_state.hpp"

namespace grains {
namespace {

// The same file: one path a link (symbolic or hard) to the other, or both naming it alike.
bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  return fs::equivalent(a, b, ec) || fs::absolute(a).lexically_normal() == fs::absolute(b).lexically_normal();
}

}  // namespace

void check_output_path(const std::string& output, const std::string& scene_file, const Scene& scene,
                       const std::string& source) {
  namespace fs = std::filesystem;
  if (auto dir = fs::path(output).parent_path(); !dir.empty() && !fs::is_directory(dir))
    throw SceneError(fmt::format("{}: output directory '{}' {} (output file '{}')", source, dir.string(),
                                 fs::exists(dir) ? "is a file, not a folder" : "does not exist", output));
  std::vector<std::pair<fs::path, std::string>> inputs{{scene_file, "the scene file"}};
  if (auto particles = particle_file(scene)) inputs.emplace_back(*particles, "the scene's particle file (particles.file)");
  for (const auto& [input, what] : inputs)
    if (same_file(output, input))
      throw SceneError(fmt::format("{}: output file '{}' is {} itself: name another file (--out, --table)", source, output,
                                   what));
}

}  // namespace grains
