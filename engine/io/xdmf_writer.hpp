// The XDMF companion of an H5MD file: a temporal collection of point clouds whose arrays are
// hyperslabs of particles/all/*/value, so ParaView can open a run without a plugin.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace grains {

// The XDMF companion's path: the HDF5 file's with the extension .xdmf.
std::string xdmf_path_beside(const std::string& hdf5_path);

class XdmfWriter {
 public:
  // `h5_name` is written as given (a bare file name keeps the pair relocatable).
  XdmfWriter(std::string xdmf_path, std::string h5_name, int dimension);

  // A per-particle array at `dataset` (e.g. "/particles/all/mass/value"): components == 1 means a
  // [frames, N] dataset shown as Scalar, 3 a [frames, N, 3] dataset shown as Vector.
  void add_field(std::string name, std::string dataset, int components);

  // Records frame `index` (its row in the datasets) with `count` particles, and the current
  // dataset shape [frames, max_count, ...] that every reference must quote.
  void add_frame(std::size_t index, double time, std::size_t count, std::size_t frames, std::size_t max_count);

  // Rewrites the whole file through a temporary and a rename, so a reader never sees half of it.
  void write() const;

  const std::string& path() const { return path_; }

 private:
  struct Field { std::string name, dataset; int components; };
  struct Frame { std::size_t index; double time; std::size_t count; };

  std::string slab(const std::string& dataset, std::size_t index, std::size_t count, int components) const;

  std::string path_, h5_name_;
  int dimension_;
  std::vector<Field> fields_;
  std::vector<Frame> frames_;
  std::size_t total_frames_ = 0, max_count_ = 0;
};

}  // namespace grains
