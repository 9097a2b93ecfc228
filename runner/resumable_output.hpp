// An output file that holds a run `grains resume` can continue is not written over by `grains run` or `grains
// consolidate` unless --overwrite says so: the default output name (<scene.name>.h5) made running a scene again after
// an interruption replace hours of work without a word. Any other existing file (a finished run, a failed one, one
// without a valid checkpoint, a file that is not a grains output) is replaced as before.
#pragma once
#include <optional>
#include <string>

namespace grains {

class Scene;

// The run about to be written, when its length is known: a stored scene the same as its own (every key, and the
// folder its relative paths lie in) has its length, and is not built again to find it.
struct RunAboutToStart {
  const Scene& scene;
  long steps;
};

class ResumableOutput {
 public:
  // Looks at `path` when it names an existing regular file: first a child process reads it as a resume would
  // (resume_probe.hpp), so call this before anything starts OpenMP's threads. A file HDF5 dies reading is no run to
  // resume. With `overwrite` nothing is looked at.
  ResumableOutput(const std::string& path, bool overwrite);

  // Throws SceneError when the file holds a run or programme with a valid checkpoint: the message names `source`
  // (--out, output.file, ...), the file, where the run stopped (the step, and of how many when the stored scene says;
  // a programme's stage), and the ways on: `grains resume FILE`, --overwrite, or another name (`other_names`: the
  // options that name the outputs). Finding a run's length builds its stored scene's simulation, unless it is
  // `about_to_start`'s scene (random insertion of 10^6 spheres takes one to two minutes): `show_progress` shows a long
  // preparation's status line meanwhile (progress.hpp).
  void refuse_replacing_it(const std::string& source, const std::string& other_names, bool show_progress,
                           std::optional<RunAboutToStart> about_to_start = std::nullopt) const;

 private:
  std::string path_;
  bool readable_ = false;   // an existing file this process may read with HDF5
};

}  // namespace grains
