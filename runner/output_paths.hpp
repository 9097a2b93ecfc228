// The files a command is about to write must not destroy what the run reads: checked before any is opened.
#pragma once
#include <string>

namespace grains {

class Scene;

// An output file the run may write: its folder exists and it is none of the run's inputs, the scene file and its
// particle file (particles.file), compared as files (links to them included). `source` names where the path came
// from (--out, output.file, ...) and leads the message.
void check_output_path(const std::string& output, const std::string& scene_file, const Scene& scene,
                       const std::string& source);

}  // namespace grains
