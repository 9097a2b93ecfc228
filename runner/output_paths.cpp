#include "output_paths.hpp"

#include <system_error>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "io/file_kind.hpp"
#include "io/scene.hpp"
#include "io/xdmf_writer.hpp"
#include "protocols/initial_state.hpp"

namespace grains {
namespace {

// The files the run reads, with what they are, for the messages.
std::vector<std::pair<std::filesystem::path, std::string>> run_inputs(const std::string& scene_file, const Scene& scene) {
  std::vector<std::pair<std::filesystem::path, std::string>> inputs{{scene_file, "the scene file"}};
  if (auto particles = particle_file(scene)) inputs.emplace_back(*particles, "the scene's particle file (particles.file)");
  return inputs;
}

void check_name_and_folder(const std::string& output, const std::string& source) {
  namespace fs = std::filesystem;
  if (output.empty()) throw SceneError(fmt::format("{}: the output file name is empty: name a file", source));
  // A name the system refuses (too long, a loop of links): said now, naming the option, not as a raw filesystem
  // error or once other outputs are written.
  std::error_code ec;
  const auto dir = fs::path(output).parent_path();
  if (!dir.empty() && !fs::is_directory(dir, ec)) {
    if (ec && ec != std::errc::no_such_file_or_directory)
      throw SceneError(fmt::format("{}: cannot use the output directory '{}': {} (output file '{}')", source, dir.string(),
                                   ec.message(), output));
    throw SceneError(fmt::format("{}: output directory '{}' {} (output file '{}')", source, dir.string(),
                                 fs::exists(dir, ec) ? "is a file, not a folder" : "does not exist", output));
  }
  static_cast<void>(fs::status(output, ec));   // whether the system can look at it: what it is, below
  if (ec && ec != std::errc::no_such_file_or_directory)
    throw SceneError(fmt::format("{}: cannot use the output file '{}': {}", source, output, ec.message()));
  // A folder was found only when writing to it, after other outputs were begun; a FIFO or a device is no file to keep.
  if (const auto kind = not_a_regular_file(output))
    throw SceneError(fmt::format("{}: output file '{}' is {}: name a file (a regular file, or a new name)", source,
                                 output, *kind));
}

}  // namespace

std::pair<std::string, std::string> hdf5_output_name(const Scene& scene, const std::string& out_option,
                                                     const std::string& default_suffix) {
  if (!out_option.empty()) return {out_option, "--out"};
  if (scene.has("output.file")) return {scene.text("output.file"), "output.file"};
  return {scene.text("scene.name") + default_suffix,
          fmt::format("scene.name (the default output file <scene.name>{})", default_suffix)};
}

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::equivalent(a, b, ec)) return true;
  const auto absolute_a = fs::absolute(a, ec).lexically_normal();
  return !ec && absolute_a == fs::absolute(b, ec).lexically_normal() && !ec;
}

std::optional<std::string> xdmf_beside(const std::string& hdf5, const Scene& scene) {
  if (!scene.boolean("output.xdmf")) return std::nullopt;
  return xdmf_path_beside(hdf5);
}

void check_output_path(const std::string& output, const std::string& scene_file, const Scene& scene,
                       const std::string& source) {
  check_name_and_folder(output, source);
  for (const auto& [input, what] : run_inputs(scene_file, scene))
    if (same_file(output, input))
      throw SceneError(fmt::format("{}: output file '{}' is {} itself: name another file (--out, --table)", source, output,
                                   what));
}

void check_hdf5_output_path(const std::string& hdf5, const std::string& scene_file, const Scene& scene,
                            const std::string& source) {
  check_output_path(hdf5, scene_file, scene, source);
  const auto xdmf = xdmf_beside(hdf5, scene);
  if (!xdmf) return;
  if (same_file(*xdmf, hdf5))
    throw SceneError(fmt::format("{}: output file '{}' ends in .xdmf: the XDMF file written beside it (the same name with "
                                 ".xdmf) would overwrite it; name the HDF5 file FILE.h5 (or set output.xdmf = false)",
                                 source, hdf5));
  for (const auto& [input, what] : run_inputs(scene_file, scene))
    if (same_file(*xdmf, input))
      throw SceneError(fmt::format("{}: the XDMF file written beside output file '{}' would be '{}', {} itself: name "
                                   "another output file (or set output.xdmf = false)", source, hdf5, *xdmf, what));
  // XDMF 2 readers (ParaView's, VTK's) cut a data item's "file:dataset" at its first colon: 'a:b.h5' read as 'b.h5'.
  if (const std::string name = std::filesystem::path(hdf5).filename().string(); name.find(':') != std::string::npos)
    throw SceneError(fmt::format("{}: output file '{}': its name holds ':', which the XDMF file written beside it cannot "
                                 "name (ParaView's XDMF readers take ':' as the end of the file name); name the file "
                                 "without ':' (or set output.xdmf = false)", source, hdf5));
  if (const auto kind = not_a_regular_file(*xdmf))
    throw SceneError(fmt::format("{}: the XDMF file written beside output file '{}' would be '{}', which is {}: name "
                                 "another output file (or set output.xdmf = false)", source, hdf5, *xdmf, *kind));
}

}  // namespace grains
