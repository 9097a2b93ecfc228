// Reading what a resume reads (see h5md_resume_reads.hpp). Opening an object is what decodes its header: a dataset's
// type, shape, fill value, filters and layout (with a virtual dataset's mappings, from the global heap); its
// attributes are decoded as they are opened and read. A resume also deletes the XDMF views of the frames it drops,
// which decodes their headers as opening them does; those of the frames it keeps it only looks up, and they are not
// read here (one damaged there does not stop a resume, and a long run's file has thousands).
#include "io/h5md_resume_reads.hpp"

#include <algorithm>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "io/h5md_checkpoint.hpp"
#include "io/h5md_checkpoint_slots.hpp"
#include "io/h5md_hdf5.hpp"
#include "io/xdmf_views.hpp"

namespace grains {

namespace {

// grains nests objects four deep (/particles/all/box/edges/value); a damaged link could make a group its own member.
constexpr int kMaxDepth = 8;

using Tell = std::function<void(const std::string&)>;
using Slots = std::vector<std::pair<int, double>>;

// What every object's reading needs: the file's size (no value is larger), the first frame whose XDMF views a resume
// may drop, and whom to tell what is read next.
struct Reading {
  hsize_t file_bytes = 0;
  std::size_t first_dropped_frame = 0;
  const Tell& tell;
};

// The checkpoints marked valid, (slot, step) newest first (valid_checkpoint_slots); none where they do not read.
Slots valid_slots(hid_t file, const std::string& path, const Tell& tell) {
  try {
    tell("/grains/checkpoint_0's and /grains/checkpoint_1's attributes 'valid' and 'step'");
    const h5::Handle grains = h5::open_group(file, "grains", path);
    return valid_checkpoint_slots(grains.get(), path);
  } catch (...) {   // unreadable, or out of memory
    return {};
  }
}

// The first frame a resume may drop: the frames from the older valid checkpoint's step on (the newer one's, or the
// older one's when the newer does not restore), as the resume cuts the positions' steps. 0 where they do not read.
std::size_t first_dropped_frame(hid_t file, const Slots& slots, hsize_t file_bytes, const std::string& path,
                                const Tell& tell) {
  try {
    tell("/particles/all/position/step");
    const h5::Handle steps = h5::open_dataset(file, "particles/all/position/step", path);
    const std::vector<hsize_t> shape = h5::shape(steps.get(), path, "position/step");
    if (slots.empty() || shape.size() != 1 || shape[0] * 8 > file_bytes) return 0;
    const std::vector<long long> rows = h5::read_int64s(steps.get(), path, "position/step");
    std::size_t first = rows.size();
    for (const auto& [slot, step] : slots)
      first = std::min(first, std::size_t(std::lower_bound(rows.begin(), rows.end(), long(step)) - rows.begin()));
    return first;
  } catch (...) {   // unreadable, or out of memory: every view is read
    return 0;
  }
}

// Whether `name` in the group `where` is the XDMF view of a frame the resume keeps.
bool kept_view(const std::string& where, const std::string& name, std::size_t first_dropped) {
  const std::string views = "/grains/xdmf/";
  if (where.rfind(views, 0) != 0 || name.empty() || name.size() > 18 || name.find_first_not_of("0123456789") != name.npos)
    return false;
  const std::size_t frame = std::stoull(name);
  return frame < first_dropped && xdmf_view_path(where.substr(views.size()), frame) == where + "/" + name;
}

// An attribute's object (its path in the file) and the reading it is part of.
struct AttributeOf {
  const std::string& where;
  const Reading& reading;
};

// An attribute's value, as the resume reads those it knows: numbers as doubles, strings as stored.
herr_t read_attribute(hid_t object, const char* name, const H5A_info_t*, void* of) noexcept {
  const auto& [where, reading] = *static_cast<const AttributeOf*>(of);
  const hsize_t file_bytes = reading.file_bytes;
  try {
    reading.tell(fmt::format("{}'s attribute '{}'", where, name));
    const h5::Handle a(H5Aopen(object, name, H5P_DEFAULT), H5Aclose);
    const h5::Handle type(H5Aget_type(a.get()), H5Tclose), space(H5Aget_space(a.get()), H5Sclose);
    const hssize_t n = H5Sget_simple_extent_npoints(space.get());
    const std::size_t size = H5Tget_size(type.get());
    // A value larger than the file is damage, which the resume's own reading reports.
    if (!a || !type || n < 0 || size == 0 || double(n) * double(size) > double(file_bytes)) return 0;
    const H5T_class_t kind = H5Tget_class(type.get());
    if (kind == H5T_STRING && H5Tis_variable_str(type.get()) > 0) {
      const h5::Handle memory = h5::vlen_string_type("");
      std::vector<char*> values(std::size_t(n), nullptr);
      if (H5Aread(a.get(), memory.get(), values.data()) >= 0)
        for (char* v : values) H5free_memory(v);
    } else if (kind == H5T_STRING) {
      std::vector<char> values(std::size_t(n) * size);
      H5Aread(a.get(), type.get(), values.data());
    } else if (kind == H5T_INTEGER || kind == H5T_FLOAT) {
      std::vector<double> values(static_cast<std::size_t>(n));
      H5Aread(a.get(), H5T_NATIVE_DOUBLE, values.data());
    }
  } catch (...) {   // out of memory: the resume's own reading meets it too
  }
  return 0;
}

// Each attribute message is decoded first as the resume's lookups by name decode them: H5Aexists goes through every
// one for a name none has, and reports a damaged one as an error. HDF5's iteration builds a table of them, and crashed in
// its error path (H5A__attr_release_table) on a damaged one, where the resume's lookups gave their clear error.
// `where`: the object's path in the file, for the watcher.
void read_attributes(hid_t object, const std::string& where, const Reading& reading) {
  reading.tell(where + "'s attributes");
  if (H5Aexists(object, "no attribute is named so") < 0) return;
  hsize_t at = 0;
  AttributeOf of{where, reading};
  H5Aiterate2(object, H5_INDEX_NAME, H5_ITER_INC, &at, read_attribute, &of);
}

// The dataset `name` at `where` (its path in the file).
void read_dataset(hid_t dataset, const std::string& name, const std::string& where, const Reading& reading) {
  read_attributes(dataset, where, reading);
  reading.tell(where);
  const h5::Handle type(H5Dget_type(dataset), H5Tclose), space(H5Dget_space(dataset), H5Sclose),
      dcpl(H5Dget_create_plist(dataset), H5Pclose);
  if (!type || !space || !dcpl) return;
  const H5D_layout_t layout = H5Pget_layout(dcpl.get());
  if (layout == H5D_VIRTUAL) {   // the XDMF views: each mapping's selections and source names
    std::size_t mappings = 0;
    H5Pget_virtual_count(dcpl.get(), &mappings);
    for (std::size_t k = 0; k < mappings; ++k) {
      H5Sclose(H5Pget_virtual_vspace(dcpl.get(), k));
      H5Sclose(H5Pget_virtual_srcspace(dcpl.get(), k));
      H5Pget_virtual_filename(dcpl.get(), k, nullptr, 0);
      H5Pget_virtual_dsetname(dcpl.get(), k, nullptr, 0);
    }
  }
#if H5_VERSION_GE(1, 10, 5)
  if (layout == H5D_CHUNKED) {   // the chunk index, which the resume's checks of the layout walk
    reading.tell(where + "'s chunk index");
    hsize_t chunks = 0;
    if (H5Dget_num_chunks(dataset, space.get(), &chunks) >= 0 && chunks > 0) {
      std::vector<hsize_t> offset(H5S_MAX_RANK);
      unsigned filters = 0;
      haddr_t address = 0;
      hsize_t bytes = 0;
      H5Dget_chunk_info(dataset, space.get(), 0, offset.data(), &filters, &address, &bytes);
    }
  }
#endif
  // A series' steps and times, which the resume reads whole to find where to cut it back.
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  const H5T_class_t kind = H5Tget_class(type.get());
  if ((name == "step" || name == "time") && (kind == H5T_INTEGER || kind == H5T_FLOAT) && n > 0 &&
      hsize_t(n) * 8 <= reading.file_bytes) {
    reading.tell(where + "'s values");
    std::vector<double> values(static_cast<std::size_t>(n));
    H5Dread(dataset, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
  }
}

// The group `where` (its path in the file) and its members.
void read_group(hid_t group, const std::string& where, int depth, const Reading& reading) {
  read_attributes(group, where, reading);
  if (depth >= kMaxDepth) return;
  reading.tell(where + "'s list of members");
  std::vector<std::string> members;
  auto collect = [](hid_t, const char* name, const H5L_info_t* info, void* out) -> herr_t {
    // grains makes hard links only: a soft or external one (another file) is not the resume's to read
    if (info->type == H5L_TYPE_HARD) static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  };
  H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &members);
  for (const std::string& name : members) {
    if (kept_view(where, name, reading.first_dropped_frame)) continue;
    try {
      const std::string member_path = where + "/" + name;
      reading.tell(member_path);
      const h5::Handle member(H5Oopen(group, name.c_str(), H5P_DEFAULT), H5Oclose);
      if (!member) continue;
      if (H5Iget_type(member.get()) == H5I_GROUP) read_group(member.get(), member_path, depth + 1, reading);
      if (H5Iget_type(member.get()) == H5I_DATASET) read_dataset(member.get(), name, member_path, reading);
    } catch (...) {   // out of memory: the resume's own reading meets it too
    }
  }
}

// What read_checkpoint(path, skip) reads for the resume: the checkpoint it restores and what comes with it.
std::string checkpoint_read(const Slots& slots, int skip) {
  const std::string with = "read as the resume reads it, with /parameters/scene.toml and the first frame's radius, mass "
                           "and position";
  if (std::size_t(skip) >= slots.size()) return "the checkpoints, " + with;
  return fmt::format("/grains/{} (the {} checkpoint, step {}), {}", checkpoint_slot_name(slots[skip].first),
                     skip == 0 ? "newest" : "older", long(slots[skip].second), with);
}

}  // namespace

void read_what_a_resume_reads(const std::string& path, const Tell& tell) noexcept {
  try {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    // A file being written may read as damaged; the resume's own reading refuses it, naming the writer.
    if (h5::locked_by_another_process(path)) return;
    Slots slots;
    {
      tell("the file's superblock and root group");
      const h5::Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
      if (!file) return;
      hsize_t file_bytes = 0;
      H5Fget_filesize(file.get(), &file_bytes);
      slots = valid_slots(file.get(), path, tell);
      const Reading reading{file_bytes, first_dropped_frame(file.get(), slots, file_bytes, path, tell), tell};
      for (const char* name : {"particles", "observables", "grains", "parameters"}) {
        const std::string where = std::string("/") + name;
        tell(where);
        if (H5Lexists(file.get(), name, H5P_DEFAULT) <= 0) continue;
        const h5::Handle group(H5Oopen(file.get(), name, H5P_DEFAULT), H5Oclose);
        if (group && H5Iget_type(group.get()) == H5I_GROUP) read_group(group.get(), where, 1, reading);
      }
      tell("the file, closing it");
    }
    for (int skip : {0, 1}) {   // the older checkpoint is read when the newest does not restore
      try {
        tell(checkpoint_read(slots, skip));
        read_checkpoint(path, skip);
      } catch (...) {   // a file the resume refuses, with its own message
      }
    }
  } catch (...) {   // out of memory: the resume's own reading meets it too
  }
  H5Eclear2(H5E_DEFAULT);
}

}  // namespace grains
