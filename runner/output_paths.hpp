// The files a command is about to write must not destroy what the run reads, nor each other: checked before any
// is opened.
#pragma once
#include <filesystem>
#include <optional>
#include <string>

namespace grains {

class Scene;

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
