// Virtual datasets behind the XDMF companion (see xdmf_views.hpp).
#include "io/xdmf_views.hpp"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <string>

#include <fmt/format.h>

#include "io/h5md_hdf5.hpp"

namespace grains {

namespace {

h5::Handle view_group(hid_t file, const std::string& name, const std::string& path) {
  h5::Handle grains = h5::open_or_create_group(file, "grains", path);
  h5::Handle xdmf = h5::open_or_create_group(grains.get(), "xdmf", path);
  return h5::open_or_create_group(xdmf.get(), name, path);
}

void write_view(hid_t group, const XdmfView& v, std::size_t frame, std::size_t count, const std::string& path) {
  const std::string name = std::to_string(frame), what = xdmf_view_path(v.name, frame);
  if (h5::exists(group, name, path)) return;
  h5::Handle source = h5::open_dataset(group, v.source, path);
  h5::Handle source_space(h5::check(H5Dget_space(source.get()), path, "selecting in " + v.source), H5Sclose);
  const hsize_t mapped = hsize_t(std::min(v.components, v.shown));   // the columns the source has
  std::vector<hsize_t> start{frame, 0}, block{1, count};
  if (v.components > 1) start.push_back(0), block.push_back(mapped);
  h5::check(H5Sselect_hyperslab(source_space.get(), H5S_SELECT_SET, start.data(), nullptr, block.data(), nullptr), path,
            "selecting in " + v.source);

  std::vector<hsize_t> dims{count};
  if (v.shown > 1) dims.push_back(hsize_t(v.shown));
  h5::Handle view_space(h5::check(H5Screate_simple(int(dims.size()), dims.data(), nullptr), path, what), H5Sclose);
  std::vector<hsize_t> view_start(dims.size(), 0), view_block{count};
  if (v.shown > 1) view_block.push_back(mapped);
  h5::check(H5Sselect_hyperslab(view_space.get(), H5S_SELECT_SET, view_start.data(), nullptr, view_block.data(), nullptr),
            path, "selecting in " + what);

  h5::Handle dcpl(h5::check(H5Pcreate(H5P_DATASET_CREATE), path, "creating " + what), H5Pclose);
  const double zero = 0.0;   // what the view shows where the source has no column: z of a 2D run
  h5::check(H5Pset_fill_value(dcpl.get(), H5T_NATIVE_DOUBLE, &zero), path, "setting the fill value of " + what);
  // "." is this file: the pair of files stays relocatable.
  h5::check(H5Pset_virtual(dcpl.get(), view_space.get(), ".", v.source.c_str(), source_space.get()), path,
            "mapping " + what);
  h5::Handle set(h5::check(H5Dcreate2(group, name.c_str(), H5T_IEEE_F64LE, view_space.get(), H5P_DEFAULT, dcpl.get(),
                                      H5P_DEFAULT), path, "creating " + what),
                 H5Dclose);
}

}  // namespace

std::string xdmf_view_path(const std::string& name, std::size_t frame) {
  return fmt::format("/grains/xdmf/{}/{}", name, frame);
}

std::string xdmf_vertices_path() { return "/grains/xdmf/vertices"; }

void write_xdmf_views(hid_t file, const std::vector<XdmfView>& views, std::size_t frame, std::size_t count,
                      const std::string& path) {
  for (const XdmfView& v : views) write_view(view_group(file, v.name, path).get(), v, frame, count, path);
}

void drop_xdmf_views_from(hid_t file, std::size_t first, const std::string& path) {
  if (!h5::exists(file, "grains", path) || !h5::exists(file, "grains/xdmf", path)) return;
  try {
    h5::Handle xdmf = h5::open_group(file, "grains/xdmf", path);
    for (const std::string& name : h5::link_names(xdmf.get(), path, "/grains/xdmf")) {
      if (name == "vertices") continue;
      h5::Handle g = h5::open_group(xdmf.get(), name, path);
      for (std::size_t k = first; h5::exists(g.get(), std::to_string(k), path); ++k)   // views are made in frame order
        h5::check(H5Ldelete(g.get(), std::to_string(k).c_str(), H5P_DEFAULT), path, "removing " + xdmf_view_path(name, k));
    }
  } catch (const std::exception&) {   // damaged after all: every view goes
    set_aside_xdmf_views(file, path);
  }
}

void set_aside_xdmf_views(hid_t file, const std::string& path) {
  if (!h5::exists(file, "grains", path) || !h5::exists(file, "grains/xdmf", path)) return;
  h5::Handle grains = h5::open_group(file, "grains", path);
  h5::set_aside(grains.get(), "xdmf", path, "setting aside the XDMF views (/grains/xdmf)");
}

void write_xdmf_vertices(hid_t file, std::size_t count, const std::string& path) {
  h5::Handle grains = h5::open_or_create_group(file, "grains", path);
  h5::Handle xdmf = h5::open_or_create_group(grains.get(), "xdmf", path);
  const std::string what = xdmf_vertices_path();
  if (h5::exists(xdmf.get(), "vertices", path)) {
    h5::Handle old = h5::open_dataset(xdmf.get(), "vertices", path);
    if (h5::shape(old.get(), path, what).at(0) >= count) return;
    old.reset();
    h5::check(H5Ldelete(xdmf.get(), "vertices", H5P_DEFAULT), path, "replacing " + what);
  }
  std::vector<std::int64_t> indices(count);
  std::iota(indices.begin(), indices.end(), std::int64_t{0});
  const hsize_t dims[1] = {count};
  h5::Handle space(h5::check(H5Screate_simple(1, dims, nullptr), path, what), H5Sclose);
  h5::Handle set(h5::check(H5Dcreate2(xdmf.get(), "vertices", H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT,
                                      H5P_DEFAULT), path, "creating " + what),
                 H5Dclose);
  if (count > 0)
    h5::check(H5Dwrite(set.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, indices.data()), path, "writing " + what);
}

}  // namespace grains
