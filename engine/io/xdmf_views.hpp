// The datasets the XDMF companion points at: for every frame and shown array, an HDF5 virtual dataset
// (/grains/xdmf/<array>/<frame>) that maps one row of particles/all/<array>/value, so each XDMF array is a
// plain dataset reference. ParaView's Xdmf3 readers read no hyperslab of a larger dataset (a 3D file showed
// no points, a 2D one crashed ParaView), and vectors are shown with three components (ParaView's wish), the
// missing z of 2D runs read as 0. The views hold no data of their own.
#pragma once
#include <cstddef>
#include <string>
#include <vector>

#include <hdf5.h>

namespace grains {

struct XdmfView {
  std::string name;    // the array's name in ParaView and under /grains/xdmf
  std::string source;  // its H5MD element's value dataset, e.g. "/particles/all/velocity/value"
  int components;      // per particle in the source: 1 (a [frames, N] dataset) or 2..4 (a [frames, N, c] one)
  int shown;           // per particle in the view: 1, or 3 for a vector (source components beyond 3 are left out)
};

// "/grains/xdmf/<name>/<frame>".
std::string xdmf_view_path(const std::string& name, std::size_t frame);
// "/grains/xdmf/vertices": 0, 1, ..., the polyvertex connectivity (Xdmf3 readers make no cells without it).
std::string xdmf_vertices_path();

// Makes the views of frame `frame` (its first `count` particles), where they do not exist yet.
void write_xdmf_views(hid_t file, const std::vector<XdmfView>& views, std::size_t frame, std::size_t count,
                      const std::string& path);
// Removes the views of frames `first` and later, of every array: for a file its run closed whole (stopped by Ctrl-C or
// SIGTERM). Where that fails, it sets them all aside (below).
void drop_xdmf_views_from(hid_t file, std::size_t first, const std::string& path);
// Sets every view aside, for a resumed run to make those of the frames it keeps anew: for a file whose run was killed. A kill while HDF5 wrote the
// views can leave their groups damaged: a lookup or a removal there failed ("bad heap free list", "address of object
// past end of allocation"), or, with no call failing, later views went missing from the group's listing (12 of 36
// after a resume). The views hold no data, so the whole group is unlinked, its reference count raised first, for
// HDF5 would otherwise free it, walking the damaged links (and fail there too); its space stays unused in the file,
// which no longer reaches it. Found by killing runs at chosen writes of HDF5 (tests/python/test_runner_killed_mid_write.py).
void set_aside_xdmf_views(hid_t file, const std::string& path);
// Makes the connectivity dataset hold at least `count` indices.
void write_xdmf_vertices(hid_t file, std::size_t count, const std::string& path);

}  // namespace grains
