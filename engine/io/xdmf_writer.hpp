// The XDMF companion of an H5MD file: a temporal collection of point clouds whose arrays are the
// per-frame views of particles/all/*/value (xdmf_views.hpp), so ParaView opens a run without a plugin,
// with its XDMF reader or its Xdmf3 readers.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace grains {

// The XDMF companion's path: the HDF5 file's with the extension .xdmf.
std::string xdmf_path_beside(const std::string& hdf5_path);

// Removes the XDMF file beside `hdf5_path` if it describes a file of that name: an earlier run's companion, whose
// arrays the new file (written without one) does not hold. A file there that names no such arrays is left alone.
void remove_stale_xdmf_beside(const std::string& hdf5_path);

class XdmfWriter {
 public:
  // `h5_name` is written as given (a bare file name keeps the pair relocatable).
  XdmfWriter(std::string xdmf_path, std::string h5_name);

  // A per-particle array shown with `components` values (1: Scalar, 3: Vector), read from the views
  // named `name` (xdmf_view_path); "position", always three components, is the geometry.
  void add_field(std::string name, int components);

  // Records frame `index` (its row in the datasets) with `count` particles.
  void add_frame(std::size_t index, double time, std::size_t count);

  // Rewrites the whole file through a temporary and a rename, so a reader never sees half of it.
  void write() const;

  const std::string& path() const { return path_; }

 private:
  struct Field { std::string name; int components; };
  struct Frame { std::size_t index; double time; std::size_t count; };

  std::string data_item(const std::string& dataset, std::size_t count, int components, const char* number_type,
                        int precision) const;

  std::string path_, h5_name_;
  std::vector<Field> fields_;
  std::vector<Frame> frames_;
};

}  // namespace grains
