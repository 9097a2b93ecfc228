// XDMF 2 companion file (see xdmf_writer.hpp). Xdmf 2 generates the trivial connectivity 0..n-1 for a
// Polyvertex topology without a DataItem, so no index array has to be stored in the HDF5 file.
#include "io/xdmf_writer.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "io/output_error.hpp"
#include "io/xml_escape.hpp"

namespace grains {

std::string xdmf_path_beside(const std::string& hdf5_path) {
  return std::filesystem::path(hdf5_path).replace_extension(".xdmf").string();
}

XdmfWriter::XdmfWriter(std::string xdmf_path, std::string h5_name, int dimension)
    : path_(std::move(xdmf_path)), h5_name_(std::move(h5_name)), dimension_(dimension) {}

void XdmfWriter::add_field(std::string name, std::string dataset, int components) {
  fields_.push_back({std::move(name), std::move(dataset), components});
}

void XdmfWriter::add_frame(std::size_t index, double time, std::size_t count, std::size_t frames,
                           std::size_t max_count) {
  if (count > 0) frames_.push_back({index, time, count});  // an empty point set confuses readers
  total_frames_ = frames;
  max_count_ = max_count;
}

// Row `index`, first `count` particles of a [frames, max_count(, components)] dataset.
std::string XdmfWriter::slab(const std::string& dataset, std::size_t index, std::size_t count,
                             int components) const {
  const bool vector = components > 1;
  std::string result_dims = vector ? fmt::format("{} {}", count, components) : fmt::format("{}", count);
  std::string selection = vector ? fmt::format("{} 0 0  1 1 1  1 {} {}", index, count, components)
                                 : fmt::format("{} 0  1 1  1 {}", index, count);
  std::string file_dims = vector ? fmt::format("{} {} {}", total_frames_, max_count_, components)
                                 : fmt::format("{} {}", total_frames_, max_count_);
  return fmt::format(
      "        <DataItem ItemType=\"HyperSlab\" Type=\"HyperSlab\" Dimensions=\"{}\">\n"
      "          <DataItem Dimensions=\"3 {}\" Format=\"XML\">{}</DataItem>\n"
      "          <DataItem Dimensions=\"{}\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{}:{}</DataItem>\n"
      "        </DataItem>\n",
      result_dims, vector ? 3 : 2, selection, file_dims, xml_escape(h5_name_), dataset);
}

void XdmfWriter::write() const {
  std::string xml =
      "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n  <Domain>\n"
      "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Frame& f : frames_) {
    xml += fmt::format("    <Grid Name=\"frame_{}\" GridType=\"Uniform\">\n      <Time Value=\"{:.17g}\"/>\n", f.index,
                       f.time);
    xml += fmt::format("      <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{}\" NodesPerElement=\"1\"/>\n",
                       f.count);
    xml += fmt::format("      <Geometry GeometryType=\"{}\">\n", dimension_ == 2 ? "XY" : "XYZ");
    xml += slab("/particles/all/position/value", f.index, f.count, dimension_);
    xml += "      </Geometry>\n";
    for (const Field& a : fields_) {
      xml += fmt::format("      <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"Node\">\n", a.name,
                         a.components > 1 ? "Vector" : "Scalar");
      xml += slab(a.dataset, f.index, f.count, a.components);
      xml += "      </Attribute>\n";
    }
    xml += "    </Grid>\n";
  }
  xml += "    </Grid>\n  </Domain>\n</Xdmf>\n";

  // Write beside the target and rename: the rename is atomic, so the .xdmf is never half written.
  const std::string temp = path_ + ".tmp";
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << xml;
    out.flush();
    if (!out) throw OutputError(fmt::format("XDMF output: cannot write '{}' ({})", temp, std::strerror(errno)));
  }
  std::error_code ec;
  std::filesystem::rename(temp, path_, ec);
  if (ec) throw OutputError(fmt::format("XDMF output: cannot rename '{}' to '{}': {}", temp, path_, ec.message()));
}

}  // namespace grains
