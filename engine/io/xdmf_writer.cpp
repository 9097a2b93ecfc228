// XDMF 2 companion file (see xdmf_writer.hpp). Every array is a plain reference to a dataset of one frame
// (a view, xdmf_views.hpp): ParaView's Xdmf3 readers read no HyperSlab items. The polyvertex topology names
// its connectivity (0, 1, ...) explicitly: the XDMF 2 reader makes it up when absent, the Xdmf3 readers
// make no cells.
#include "io/xdmf_writer.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <fmt/format.h>

#include "io/output_error.hpp"
#include "io/xdmf_views.hpp"
#include "io/xml_escape.hpp"

namespace grains {

std::string xdmf_path_beside(const std::string& hdf5_path) {
  return std::filesystem::path(hdf5_path).replace_extension(".xdmf").string();
}

void remove_stale_xdmf_beside(const std::string& hdf5_path) {
  const std::string xdmf = xdmf_path_beside(hdf5_path);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(xdmf, ec) || std::filesystem::file_size(xdmf, ec) > (std::uintmax_t(1) << 30)) return;
  std::ifstream in(xdmf);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string reference = "Format=\"HDF\">" + xml_escape(std::filesystem::path(hdf5_path).filename().string()) + ":/";
  if (in && text.find(reference) != std::string::npos) std::filesystem::remove(xdmf, ec);
}

XdmfWriter::XdmfWriter(std::string xdmf_path, std::string h5_name)
    : path_(std::move(xdmf_path)), h5_name_(std::move(h5_name)) {}

void XdmfWriter::add_field(std::string name, int components) {
  fields_.push_back({std::move(name), components});
}

void XdmfWriter::add_frame(std::size_t index, double time, std::size_t count) {
  if (count > 0) frames_.push_back({index, time, count});  // an empty point set confuses readers
}

std::string XdmfWriter::data_item(const std::string& dataset, std::size_t count, int components,
                                  const char* number_type, int precision) const {
  const std::string dims = components > 1 ? fmt::format("{} {}", count, components) : fmt::format("{}", count);
  return fmt::format("        <DataItem Dimensions=\"{}\" NumberType=\"{}\" Precision=\"{}\" Format=\"HDF\">{}:{}</DataItem>\n",
                     dims, number_type, precision, xml_escape(h5_name_), dataset);
}

void XdmfWriter::write() const {
  std::string xml =
      "<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n<Xdmf Version=\"2.0\">\n  <Domain>\n"
      "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const Frame& f : frames_) {
    xml += fmt::format("    <Grid Name=\"frame_{}\" GridType=\"Uniform\">\n      <Time Value=\"{:.17g}\"/>\n", f.index,
                       f.time);
    xml += fmt::format("      <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{}\" NodesPerElement=\"1\">\n",
                       f.count);
    xml += data_item(xdmf_vertices_path(), f.count, 1, "Int", 8);
    xml += "      </Topology>\n      <Geometry GeometryType=\"XYZ\">\n";
    xml += data_item(xdmf_view_path("position", f.index), f.count, 3, "Float", 8);
    xml += "      </Geometry>\n";
    for (const Field& a : fields_) {
      xml += fmt::format("      <Attribute Name=\"{}\" AttributeType=\"{}\" Center=\"Node\">\n", a.name,
                         a.components > 1 ? "Vector" : "Scalar");
      xml += data_item(xdmf_view_path(a.name, f.index), f.count, a.components, "Float", 8);
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
    if (!out) {
      const int why = errno;
      out.close();
      std::error_code ignored;
      std::filesystem::remove(temp, ignored);   // a truncated temporary helps no one (a full disk left one each time)
      throw OutputError(fmt::format("XDMF output: cannot write '{}' ({})", temp, std::strerror(why)));
    }
  }
  std::error_code ec;
  std::filesystem::rename(temp, path_, ec);
  if (ec) throw OutputError(fmt::format("XDMF output: cannot rename '{}' to '{}': {}", temp, path_, ec.message()));
}

}  // namespace grains
