// The files a command is about to write must not destroy what the run reads, nor each other: checked before any
// is opened.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <utility>

namespace grains {

class Scene;

// A command's HDF5 output and what named it (for messages): `out_option` (--out) if given, else output.file, else
// <scene.name><default_suffix> (run: ".h5"; consolidate: "-stages.h5").
std::pair<std::string, std::string> hdf5_output_name(const Scene& scene, const std::string& out_option,
                                                     const std::string& default_suffix);

// The same file: one path a link (symbolic or hard) to the other, or both naming it alike.
bool same_file(const std::filesystem::path& a, const std::filesystem::path& b);

// The XDMF file written beside an HDF5 output (the same name with .xdmf) when output.xdmf is on.
std::optional<std::string> xdmf_beside(const std::string& hdf5, const Scene& scene);

// An output file the run may write: a name, in a folder that exists, and none of the run's inputs, the scene file
// and its particle file (particles.file), compared as files (links to them included). `source` names where the
// path came from (--out, output.file, ...) and leads the message.
void check_output_path(const std::string& output, const std::string& scene_file, const Scene& scene,
                       const std::string& source);

// An HDF5 output checked as above, and the XDMF file beside it too: that must be neither an input nor the
// HDF5 file itself (an output named x.xdmf).
void check_hdf5_output_path(const std::string& hdf5, const std::string& scene_file, const Scene& scene,
                            const std::string& source);

}  // namespace grains
