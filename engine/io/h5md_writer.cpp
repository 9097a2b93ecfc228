// H5MD 1.1 writer (see h5md_writer.hpp). Every time-dependent element is a group with extendable
// step/time/value datasets; each frame appends one row and flushes, so a killed run leaves a
// readable file holding every frame written so far. Observables are held in memory and written, a
// block of rows per dataset, with the next flush: the first write of a new record (a new step) flushes
// when a second has passed since the last, so the file always holds whole records (a flush within one
// left its first observables a row ahead of the rest in a killed run's file). With some
// forty observables recorded every 100 steps, writing and flushing each record (three HDF5 writes per
// observable) took 10-30 % of the wall time of a 1400-disk run.
#include "io/h5md_writer.hpp"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <map>
#include <stdexcept>

#include <fmt/format.h>

#include "io/file_kind.hpp"
#include "io/h5md_checkpoint.hpp"
#include "io/h5md_checkpoint_slots.hpp"
#include "io/h5md_hdf5.hpp"
#include "io/output_error.hpp"
#include "io/xdmf_views.hpp"
#include "io/xdmf_writer.hpp"

namespace grains {

namespace {

constexpr hsize_t kObservableChunk = 1024;      // rows per chunk of observables and step/time
constexpr hsize_t kWarningChunk = 64;            // rows per chunk of /grains/warnings
constexpr hsize_t kFrameChunkBytes = 64 * 1024;  // small frames are batched to about this size
constexpr hsize_t kMaxChunkBytes = 4 * 1024 * 1024;
constexpr std::chrono::seconds kObservableFlushInterval{1};   // the most a killed run loses of them

// A time-dependent H5MD element: <group>/{step,time,value}.
struct Series {
  h5::Handle group, step, time, value;
  int components = 0;  // 0: one scalar per row or per particle
  bool shares_clock = false;  // step and time are the position's (hard links), as H5MD 1.1 requires of the box
  hsize_t kept = 0;           // a resumed file's: the rows it keeps, the resume cutting the rest once all is checked
  // Observables only: rows recorded since the last flush, not yet in the file.
  std::vector<std::int64_t> pending_step;
  std::vector<double> pending_time, pending_value;
};

}  // namespace

struct H5mdWriter::Impl {
  std::string path, xdmf_path;
  std::string scene_check;   // scene_check_sum of the stored scene, recorded with every checkpoint
  int dim = 3;
  h5::WriterLock lock;   // released after the file is closed
  h5::Handle file, particles, box, observables, grains, parameters, warnings, trace;  // `file` first: closed last
  std::map<std::string, Series> series;       // particles/all/<name> and box/<name>
  // By their path below the root: observables/<name>, and grains/trace/<name> (write_trace).
  std::map<std::string, Series> observable;
  std::size_t frames = 0, max_count = 0, xdmf_frames_on_disk = 0;
  bool has_angular = false, has_orientation = false;
  // Whether frames carry particles/all/image: from the first frame, or the resumed file (one without the element,
  // written before grains had it, goes on without it, so that its frames keep lining up).
  bool has_image = false;
  std::chrono::steady_clock::time_point last_flush = std::chrono::steady_clock::now();
  long record_step = std::numeric_limits<long>::min();   // the step of the observables' record being written
  std::unique_ptr<XdmfWriter> xdmf;
  std::vector<XdmfView> xdmf_views;         // what each frame shows, named with the first frame

  // The type of the values of the element `name` of `parent` in the file: integers for the periodic images, doubles
  // for the rest. The one place that says so: make_series creates each element with it, reopen_series checks it.
  hid_t value_type(hid_t parent, const std::string& name) const {
    return parent == particles.get() && name == "image" ? H5T_STD_I64LE : H5T_IEEE_F64LE;
  }

  // `clock`: the element whose step and time this one's are (hard links), else it gets its own.
  Series make_series(hid_t parent, const std::string& name, const std::vector<hsize_t>& inner, int components,
                     const Series* clock = nullptr) {
    const hid_t type = value_type(parent, name);
    Series s;
    s.components = components;
    s.group = h5::create_group(parent, name, path);
    if (clock) {
      for (const char* part : {"step", "time"}) h5::hard_link(clock->group.get(), part, s.group.get(), part, path);
      s.step = h5::open_dataset(s.group.get(), "step", path);
      s.time = h5::open_dataset(s.group.get(), "time", path);
      s.shares_clock = true;
    } else {
      s.step = h5::create_extendable(s.group.get(), "step", H5T_STD_I64LE, {}, {}, kObservableChunk, path);
      s.time = h5::create_extendable(s.group.get(), "time", H5T_IEEE_F64LE, {}, {}, kObservableChunk, path);
    }
    // Chunk: whole frames, several per chunk when frames are small, the particle axis cut when huge.
    hsize_t row_values = 1;
    for (hsize_t n : inner) row_values *= std::max<hsize_t>(n, 1);
    const hsize_t row_bytes = row_values * H5Tget_size(type);
    std::vector<hsize_t> chunk_inner = inner;
    if (!chunk_inner.empty() && row_bytes > kMaxChunkBytes)
      chunk_inner[0] = std::max<hsize_t>(1, chunk_inner[0] * kMaxChunkBytes / row_bytes);
    const hsize_t rows = std::clamp<hsize_t>(kFrameChunkBytes / row_bytes, 1, kObservableChunk);
    s.value = h5::create_extendable(s.group.get(), "value", type, inner, chunk_inner, rows, path);
    return s;
  }

  // `data` holds values of `memory_type`.
  void append(Series& s, const std::string& what, long step, double time, const void* data,
              const std::vector<hsize_t>& count, hid_t memory_type = H5T_NATIVE_DOUBLE) {
    const std::int64_t step64 = step;
    if (!s.shares_clock) {   // a shared clock has its row from its owner
      h5::append_row(s.step.get(), H5T_NATIVE_INT64, &step64, {}, path, what + "/step");
      h5::append_row(s.time.get(), H5T_NATIVE_DOUBLE, &time, {}, path, what + "/time");
    }
    h5::append_row(s.value.get(), memory_type, data, count, path, what + "/value");
  }

  // Appends one per-particle element, creating it on first use with this frame's particle count.
  void particle_element(const std::string& name, const H5mdFrame& f, const double* data, int components) {
    auto it = series.find(name);
    const std::vector<hsize_t> count = components > 1 ? std::vector<hsize_t>{f.count, hsize_t(components)}
                                                      : std::vector<hsize_t>{f.count};
    if (it == series.end()) it = series.emplace(name, make_series(particles.get(), name, count, components)).first;
    if (it->second.components != components)
      throw std::invalid_argument(fmt::format("H5MD output '{}': {} changed from {} to {} components", path, name,
                                              it->second.components, components));
    append(it->second, "/particles/all/" + name, f.step, f.time, data, count);
  }

  // particles/all/image (H5MD 1.1): integers shaped as the position, on the position's clock like the box.
  void image_element(const H5mdFrame& f) {
    auto it = series.find("image");
    const std::vector<hsize_t> count{f.count, hsize_t(dim)};
    if (it == series.end())
      it = series.emplace("image", make_series(particles.get(), "image", count, dim, &series.at("position"))).first;
    append(it->second, "/particles/all/image", f.step, f.time, f.image, count, H5T_NATIVE_INT64);
  }

  void box_element(const std::string& name, const H5mdFrame& f, const double* data) {
    auto it = series.find("box/" + name);
    if (it == series.end())   // H5MD 1.1: the box's step and time are hard links to the position's
      it = series.emplace("box/" + name, make_series(box.get(), name, {hsize_t(dim)}, dim, &series.at("position"))).first;
    append(it->second, "/particles/all/box/" + name, f.step, f.time, data, {hsize_t(dim)});
  }

  // The XDMF arrays, named once the first frame tells which elements the run writes. Positions and velocities
  // are shown with three components (ParaView's wish; 2D runs read z = 0), a 2D spin as a scalar.
  void register_xdmf_fields(bool angular, int angular_components) {
    xdmf_views = {{"position", "/particles/all/position/value", dim, 3},
                  {"radius", "/particles/all/radius/value", 1, 1},
                  {"mass", "/particles/all/mass/value", 1, 1},
                  {"velocity", "/particles/all/velocity/value", dim, 3}};
    if (angular && (angular_components == 1 || angular_components == 3))
      xdmf_views.push_back({"angular_velocity", "/particles/all/angular_velocity/value", angular_components,
                            angular_components});
    for (const XdmfView& v : xdmf_views)
      if (v.name != "position") xdmf->add_field(v.name, v.shown);
  }

  // An element of a file being resumed, checked, and the rows it keeps: those before `step`, and the row at `step` if
  // `at_step` (cut_back cuts it to them).
  Series reopen_series(hid_t parent, const std::string& name, long step, bool at_step) {
    Series s;
    s.group = h5::open_group(parent, name, path);
    s.step = h5::open_extendable(s.group.get(), "step", path);
    s.time = h5::open_extendable(s.group.get(), "time", path);
    s.value = h5::open_extendable(s.group.get(), "value", path);
    h5::check_as_written(s.step.get(), H5T_STD_I64LE, kObservableChunk, path, name + "/step");
    h5::check_as_written(s.time.get(), H5T_IEEE_F64LE, kObservableChunk, path, name + "/time");
    h5::check_as_written(s.value.get(), value_type(parent, name), kObservableChunk, path, name + "/value");
    const std::vector<long long> steps = h5::read_int64s(s.step.get(), path, name + "/step");
    // Cut back by a search of the steps: out of order, it would keep records after the checkpoint or drop some before.
    for (std::size_t k = 1; k < steps.size(); ++k)
      if (steps[k] <= steps[k - 1])
        throw std::runtime_error(fmt::format("H5MD output '{}': {}/step is not increasing: its row {} holds step {} after "
                                             "step {}, where grains writes each record at a later step: the file is damaged "
                                             "and cannot be continued", path, h5::path_of(s.group.get(), "."), k, steps[k],
                                             steps[k - 1]));
    s.kept = hsize_t((at_step ? std::upper_bound(steps.begin(), steps.end(), step)
                              : std::lower_bound(steps.begin(), steps.end(), step)) - steps.begin());
    // A damaged file's shorter time or value would be extended with fill values, out of step with the steps.
    for (const auto& [d, part] : {std::pair{s.time.get(), "time"}, std::pair{s.value.get(), "value"}})
      if (const hsize_t held = h5::shape(d, path, name + "/" + part).at(0); held < s.kept)
        throw std::runtime_error(fmt::format("H5MD output '{}': {}/{} holds {} rows, but {}/step names {} up to step {}: "
                                             "the file is damaged and cannot be continued", path, name, part, held, name,
                                             s.kept, step));
    const std::vector<hsize_t> shape = h5::shape(s.value.get(), path, name + "/value");
    s.components = shape.size() == 3 ? int(shape[2]) : 1;
    return s;
  }

  // A resumed file's series as the writer made them: each its own datasets (a series hard-linked to another had both
  // appended to one), the clock shared only as H5MD's box and image share the position's, every frame element with a
  // row per frame and the observables (and the trace) with a row per record, so that the rows appended go on in step.
  void check_series_apart() {
    const auto damaged = [&](const std::string& defect) {
      throw std::runtime_error(fmt::format("H5MD output '{}': {}: the file is damaged and cannot be continued", path, defect));
    };
    std::map<std::string, std::string> owner;   // an object's identity -> its path
    const auto own = [&](hid_t d) {
      const std::string where = h5::path_of(d, "."), id = h5::object_identity(d, path, where);
      if (const auto [at, fresh] = owner.emplace(id, where); !fresh)
        damaged(fmt::format("{} is the same dataset as {} (two names of one object), where grains writes each series "
                            "its own", where, at->second));
    };
    const Series* position = series.count("position") ? &series.at("position") : nullptr;
    const std::string clock = position ? h5::object_identity(position->step.get(), path, "/particles/all/position/step") : "";
    for (const auto& [name, s] : series) {
      own(s.value.get());
      if (!s.shares_clock) own(s.step.get()), own(s.time.get());
      else if (h5::object_identity(s.step.get(), path, name) != clock)
        damaged(fmt::format("{}/step is linked to another dataset than /particles/all/position/step, whose clock it shares",
                            h5::path_of(s.group.get(), ".")));
    }
    for (const auto& [name, s] : observable) own(s.value.get()), own(s.step.get()), own(s.time.get());
    // Rows kept: each frame element as many as the position, the box's edges and offset present (written with every
    // frame).
    if (position) {
      for (const char* needed : {"velocity", "radius", "mass", "box/edges", "box/offset"})
        if (!series.count(needed)) damaged(fmt::format("/particles/all/{} is missing, where grains writes it with every frame", needed));
      for (const auto& [name, s] : series)
        if (s.kept != position->kept)
          damaged(fmt::format("/particles/all/{}/value holds {} rows, where the position holds {} frames", name, s.kept,
                              position->kept));
    }
    for (const std::string group : {"observables/", "grains/trace/"}) {
      const std::pair<const std::string, Series>* first = nullptr;
      for (const auto& entry : observable) {
        if (entry.first.rfind(group, 0) != 0) continue;
        if (!first) { first = &entry; continue; }
        if (entry.second.kept != first->second.kept)
          damaged(fmt::format("/{} holds {} records, where /{} holds {} (grains writes every one in each record)",
                              entry.first, entry.second.kept, first->first, first->second.kept));
      }
    }
  }

  // Cuts every series of a resumed file back to the rows it keeps (reopen_series).
  void cut_back() {
    for (auto* group : {&series, &observable})
      for (auto& [name, s] : *group)
        for (hid_t d : {s.step.get(), s.time.get(), s.value.get()}) h5::truncate_rows(d, s.kept, path, name);
  }

  void update_xdmf(bool final) {
    if (!xdmf || xdmf_frames_on_disk == frames) return;
    // Rewriting costs O(frames); past a few hundred frames rewrite at a steady fraction so the total
    // stays linear. The file on disk then lags by at most ~3% of the frames, and is exact at close.
    if (!final && frames > 256 && frames - xdmf_frames_on_disk < frames / 32) return;
    xdmf->write();
    xdmf_frames_on_disk = frames;
  }

  // Holds one row of the series `where` + `name` (created under `parent` on first use) for the next flush.
  void record(hid_t parent, const std::string& where, const std::string& name, long step, double time, double value);

  // Writes the observables' pending rows, in order of name, then flushes.
  // The observables' pending rows go to the file (the trace's too), and then /observables@complete_to_step says up to which step
  // every series is whole. HDF5 writes the series one by one (and evicts metadata when it likes): a run killed
  // inside a flush left one series a flush ahead of the others. Readers keep the rows up to that step.
  void flush() {
    std::int64_t newest = -1;
    for (auto& [name, s] : observable) {
      const std::string what = "/" + name;
      const hsize_t rows = s.pending_step.size();
      h5::append_rows(s.step.get(), H5T_NATIVE_INT64, s.pending_step.data(), rows, {}, path, what + "/step");
      h5::append_rows(s.time.get(), H5T_NATIVE_DOUBLE, s.pending_time.data(), rows, {}, path, what + "/time");
      h5::append_rows(s.value.get(), H5T_NATIVE_DOUBLE, s.pending_value.data(), rows, {}, path, what + "/value");
      if (rows) newest = std::max(newest, s.pending_step.back());
      s.pending_step.clear(), s.pending_time.clear(), s.pending_value.clear();
    }
    h5::check(H5Fflush(file.get(), H5F_SCOPE_GLOBAL), path, "flushing the file");
    if (newest >= 0 && observables) {
      h5::attr_double(observables.get(), "complete_to_step", double(newest), path);   // exact below 2^53
      h5::check(H5Fflush(file.get(), H5F_SCOPE_GLOBAL), path, "flushing the file");
    }
    last_flush = std::chrono::steady_clock::now();
  }

  // The new file's groups, parameters and XDMF companion (H5MD 1.1), then the first flush.
  void create_layout(const std::vector<bool>& boundary_periodic, const std::string& creator_version,
                     const std::string& resolved_scene_toml, bool write_xdmf);
};

H5mdWriter::H5mdWriter(const std::string& path, int dimension, const std::vector<bool>& boundary_periodic,
                       const std::string& creator_version, const std::string& resolved_scene_toml, bool write_xdmf)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.path = path;
  m.dim = dimension;
  if (dimension != 2 && dimension != 3)
    throw std::invalid_argument(fmt::format("H5MD output '{}': dimension must be 2 or 3, got {}", path, dimension));
  if (boundary_periodic.size() != static_cast<std::size_t>(dimension))
    throw std::invalid_argument(fmt::format("H5MD output '{}': {} boundary flags given for dimension {}", path,
                                            boundary_periodic.size(), dimension));
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions, not stderr noise

  const std::filesystem::path fs_path(path);
  const std::filesystem::path dir = fs_path.has_parent_path() ? fs_path.parent_path() : ".";
  if (!std::filesystem::is_directory(dir))
    throw std::runtime_error(fmt::format("cannot create output file '{}': directory '{}' does not exist", path,
                                         dir.string()));
  // The file is made under a temporary name and renamed once its first flush has made it valid HDF5: a run
  // killed while creating it (SIGKILL) left a file of 0 or 96 bytes that nothing could open. Neither name may
  // be another process's file: H5Fcreate empties a file before it takes HDF5's lock, and the rename would
  // take the name from under a run (or an FMU's snapshots) still writing it.
  // The rename replaces what the name holds: a link is followed to its file, and a name that holds anything but a
  // file (a device such as /dev/full, a pipe) is refused, not replaced.
  std::error_code ec;
  std::filesystem::path followed = fs_path, first_link;
  int links = 0;
  for (; links < 40 && std::filesystem::is_symlink(followed, ec); ++links) {
    const std::filesystem::path to = std::filesystem::read_symlink(followed, ec);
    if (links == 0) first_link = to;
    followed = to.is_absolute() ? to : followed.parent_path() / to;
  }
  // A link into a folder that is not there: said as such, not as HDF5's failure to create the file. The folder as a
  // path from where grains runs (a link's text is relative to the link's own folder), through every link.
  if (links > 0 && followed.has_parent_path() &&
      std::filesystem::status(followed.parent_path(), ec).type() == std::filesystem::file_type::not_found)
    throw std::runtime_error(fmt::format(
        "cannot create output file '{}': the name is a link to '{}'{}, whose folder '{}' does not exist; make that "
        "folder, or name another file", path, first_link.string(),
        links > 1 ? fmt::format(", which leads on to '{}'", followed.string()) : "", followed.parent_path().string()));
  const std::string target = followed.string();
  if (const auto kind = not_a_regular_file(target))
    throw std::runtime_error(fmt::format("cannot create output file '{}': the name holds {}, not a file; name a file (a "
                                         "regular file, or a new name)", path, *kind));
  const std::string creating = target + ".part";
  for (const std::string& p : {target, creating})
    if (h5::locked_by_another_process(p))
      throw std::runtime_error(fmt::format("cannot create output file '{}': another writer holds it (a run still going, or "
                                           "an FMU instance not yet terminated whose name gives this file?); choose another file, "
                                           "or wait until that writer ends", path));
  hid_t fid = H5Fcreate(creating.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (fid < 0) h5::fail(path, fmt::format("creating the file (first as '{}'; is the folder writable?)", creating));
  m.file = h5::Handle(fid, H5Fclose);
  try {
    m.lock = h5::WriterLock(creating);   // moves with the file to its name
    m.create_layout(boundary_periodic, creator_version, resolved_scene_toml, write_xdmf);
  } catch (...) {
    impl_.reset();   // closes the file before it goes
    std::error_code ignored;
    std::filesystem::remove(creating, ignored);
    throw;
  }
  std::filesystem::rename(creating, target, ec);   // the open file (and HDF5's lock on it) moves with its name
  if (ec) {
    impl_.reset();
    std::filesystem::remove(creating, ec);
    throw OutputError(fmt::format("cannot create output file '{}': renaming '{}' to it failed ({})", path, creating,
                                  ec.message()));
  }
  // A companion an earlier run of this name left would show that run's frames, or none.
  if (!write_xdmf) remove_stale_xdmf_beside(path);
}

void H5mdWriter::Impl::create_layout(const std::vector<bool>& boundary_periodic, const std::string& creator_version,
                                     const std::string& resolved_scene_toml, bool write_xdmf) {
  Impl& m = *this;
  const int dimension = m.dim;
  const hid_t root = m.file.get();

  {
    h5::Handle h5md = h5::create_group(root, "h5md", path);
    h5::attr_ints(h5md.get(), "version", {1, 1}, false, path);
    // H5MD's author is the person who ran the simulation, not the program (that is the creator): taken from
    // the environment, as a name should not travel in shared scene files; "unknown" without it.
    h5::Handle author = h5::create_group(h5md.get(), "author", path);
    const char* name = std::getenv("GRAINS_AUTHOR");
    const char* email = std::getenv("GRAINS_AUTHOR_EMAIL");
    h5::attr_fixed_string(author.get(), "name", name && *name ? name : "unknown", path);
    if (email && *email) h5::attr_fixed_string(author.get(), "email", email, path);
    h5::Handle creator = h5::create_group(h5md.get(), "creator", path);
    h5::attr_fixed_string(creator.get(), "name", "grains", path);
    h5::attr_fixed_string(creator.get(), "version", creator_version, path);
  }

  h5::Handle particles = h5::create_group(root, "particles", path);
  m.particles = h5::create_group(particles.get(), "all", path);
  m.box = h5::create_group(m.particles.get(), "box", path);
  h5::attr_ints(m.box.get(), "dimension", {dimension}, true, path);
  std::vector<std::string> boundary;
  for (bool p : boundary_periodic) boundary.emplace_back(p ? "periodic" : "none");
  h5::attr_strings(m.box.get(), "boundary", boundary, path);

  m.observables = h5::create_group(root, "observables", path);
  m.parameters = h5::create_group(root, "parameters", path);
  h5::dataset_string(m.parameters.get(), "scene.toml", resolved_scene_toml, path);
  m.scene_check = scene_check_sum(resolved_scene_toml);
  h5::attr_string(m.parameters.get(), "scene.toml", resolved_scene_toml, path);

  m.grains = h5::create_group(root, "grains", path);
  h5::Handle vstr = h5::vlen_string_type(path);
  m.warnings = h5::create_extendable(m.grains.get(), "warnings", vstr.get(), {}, {}, kWarningChunk, path);

  if (write_xdmf) {
    m.xdmf_path = xdmf_path_beside(path);
    m.xdmf = std::make_unique<XdmfWriter>(m.xdmf_path, std::filesystem::path(path).filename().string());
  }
  m.flush();
}

H5mdWriter::H5mdWriter(const std::string& path, const RunCheckpoint& resume, bool write_xdmf,
                       const std::vector<std::string>& observables)
    : impl_(std::make_unique<Impl>()) {
  const long resume_step = resume.step;
  const bool observables_at_step = resume.observables_at_step, frame_at_step = resume.frame_at_step;
  Impl& m = *impl_;
  m.path = path;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  m.lock = h5::WriterLock(path);
  hid_t fid = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (fid < 0) h5::fail(path, "opening the file to resume its run (is it writable?)");
  m.file = h5::Handle(fid, H5Fclose);
  // A killed run's superblock can name an end of allocation short of what the run had written past it (the
  // superblock is written at flushes): HDF5 would put new objects over those bytes, and cut the file back to that
  // end when it closes, also a file refused below. From the end of the file on, nothing written is reused. (The one
  // change a refused resume makes: that end, in the superblock, where it was short.)
  h5::check(H5Fincrement_filesize(fid, 0), path, "setting the file's end of allocation to its end");
  const hid_t root = m.file.get();
  // Everything is checked before anything is cut: a file refused is left as it was (a check after the cut had refused
  // files already cut back to their checkpoint, their other slot removed, their stage table rewritten).
  // The H5MD root (version, author, creator) is what makes the file H5MD: a file without it would be continued into one
  // no H5MD reader takes.
  if (!h5::exists(root, "h5md", path))
    throw std::runtime_error(fmt::format("H5MD output '{}': /h5md, the H5MD root group grains writes first, is missing: "
                                         "the file is damaged and cannot be continued", path));
  m.particles = h5::open_group(root, "particles/all", path);
  m.box = h5::open_group(m.particles.get(), "box", path);
  m.dim = int(h5::read_attr_in(m.box.get(), "dimension", 3, 2, 3, true, path));
  m.observables = h5::open_group(root, "observables", path);
  m.parameters = h5::open_group(root, "parameters", path);
  m.scene_check = scene_check_sum(h5::read_dataset_string(root, "parameters/scene.toml", path));
  m.grains = h5::open_group(root, "grains", path);
  // The slot resumed from is kept, its layout checked: the resumed run writes its checkpoints over it.
  if (resume.slot >= 0) check_checkpoint_slot(m.grains.get(), resume.slot, path);
  m.warnings = h5::open_dataset(m.grains.get(), "warnings", path);
  h5::check_as_written(m.warnings.get(), h5::vlen_string_type(path).get(), kWarningChunk, path, "/grains/warnings");
  auto members = [&](hid_t group, const std::string& what) { return h5::link_names(group, path, what); };
  for (const auto& name : members(m.particles.get(), "/particles/all")) {
    if (name == "box") continue;
    Series& s = m.series.emplace(name, m.reopen_series(m.particles.get(), name, resume_step, frame_at_step)).first->second;
    // The image's step and time are the position's (the position's own are linked to by the box and the image).
    s.shares_clock = name != "position" && h5::link_count(s.group.get(), "step", m.path) > 1;
  }
  for (const auto& name : members(m.box.get(), "/particles/all/box")) {
    Series& s = m.series.emplace("box/" + name, m.reopen_series(m.box.get(), name, resume_step, frame_at_step)).first->second;
    s.components = m.dim;
    s.shares_clock = h5::link_count(s.group.get(), "step", path) > 1;   // files before H5MD's links have their own
  }
  for (const auto& name : members(m.observables.get(), "/observables"))
    m.observable.emplace("observables/" + name, m.reopen_series(m.observables.get(), name, resume_step, observables_at_step));
  if (h5::exists(m.grains.get(), "trace", path)) {
    m.trace = h5::open_group(m.grains.get(), "trace", path);
    for (const auto& name : members(m.trace.get(), "/grains/trace"))
      m.observable.emplace("grains/trace/" + name, m.reopen_series(m.trace.get(), name, resume_step, observables_at_step));
  }
  m.check_series_apart();
  // One missing would be made anew with only the resumed run's rows.
  for (const auto& name : observables)
    if (!m.observable.count("observables/" + name))
      throw std::runtime_error(fmt::format("H5MD output '{}': /observables/{} is missing, where the run records it with "
                                           "its other observables: the file is damaged and cannot be continued", path, name));

  // Then the cut. The other slot is removed, to be made anew by the next checkpoint. A slot newer than the resume was
  // passed over (damaged, or its state would not restore) and an invalid one may hold a chunk torn by a kill: written
  // over, a damaged newest one stayed "the newest", so the next checkpoint went over the only good one; and HDF5 reads
  // a chunk it writes only in part, which failed on a damaged one ("data error detected by Fletcher32"). An older valid
  // slot is no better a fallback than the one just read. One passed over as damaged is set aside, not freed: HDF5 failed
  // to free one whose header a flipped bit had damaged, after lowering its reference count (corrupt_resume.py).
  for (int slot : {0, 1}) {
    const std::string what = std::string("removing /grains/") + checkpoint_slot_name(slot);
    const bool damaged = std::any_of(resume.passed_over.begin(), resume.passed_over.end(),
                                     [&](const auto& passed) { return passed.slot == slot; });
    if (slot == resume.slot || !h5::exists(m.grains.get(), checkpoint_slot_name(slot), path)) continue;
    if (damaged) h5::set_aside(m.grains.get(), checkpoint_slot_name(slot), path, what);
    else h5::check(H5Ldelete(m.grains.get(), checkpoint_slot_name(slot), H5P_DEFAULT), path, what);
  }
  if (resume.warnings >= 0) h5::truncate_rows(m.warnings.get(), hsize_t(resume.warnings), path, "/grains/warnings");
  m.cut_back();
  m.has_angular = m.series.count("angular_velocity") > 0, m.has_orientation = m.series.count("orientation") > 0;
  m.has_image = m.series.count("image") > 0;
  std::vector<double> times;
  if (auto it = m.series.find("position"); it != m.series.end()) {
    times = h5::read_doubles(it->second.time.get(), path, "/particles/all/position/time");
    m.frames = times.size();
    m.max_count = h5::shape(it->second.value.get(), path, "/particles/all/position/value").at(1);
  }
  if (write_xdmf) {
    m.xdmf_path = xdmf_path_beside(path);
    m.xdmf = std::make_unique<XdmfWriter>(m.xdmf_path, std::filesystem::path(path).filename().string());
  }
  // The views of the frames dropped go. A run stopped by Ctrl-C or SIGTERM ("interrupted ...") closed its file whole: its
  // views are cut back. One killed ("running", "resumed at step N") or stopped by an output error may have left them
  // damaged without any call failing (xdmf_views.hpp): every view goes, each resume then costing the views' space (about
  // 2.6 kB a frame). The frames kept get their views anew (also where an older grains wrote none).
  if (resume.status.rfind("interrupted", 0) == 0) drop_xdmf_views_from(root, m.frames, path);
  else set_aside_xdmf_views(root, path);
  if (m.xdmf && m.frames > 0) {
    m.register_xdmf_fields(m.has_angular, m.has_angular ? m.series.at("angular_velocity").components : 0);
    write_xdmf_vertices(root, m.max_count, path);
    for (std::size_t k = 0; k < m.frames; ++k) {
      write_xdmf_views(root, m.xdmf_views, k, m.max_count, path);
      m.xdmf->add_frame(k, times[k], m.max_count);
    }
    m.xdmf->write();
    m.xdmf_frames_on_disk = m.frames;
  }
  m.flush();
}

H5mdWriter::~H5mdWriter() {
  if (!impl_ || !impl_->file) return;
  try {
    impl_->update_xdmf(true);
    impl_->flush();
  } catch (...) {
    // A destructor must not throw; the data written so far is already flushed.
  }
}

void H5mdWriter::write_frame(const H5mdFrame& f) {
  Impl& m = *impl_;
  if (f.dimension != m.dim)
    throw std::invalid_argument(fmt::format("H5MD output '{}': frame of dimension {} in a {}-D file", m.path,
                                            f.dimension, m.dim));
  if (f.count > 0 && (!f.position || !f.velocity || !f.radius || !f.mass))
    throw std::invalid_argument(fmt::format("H5MD output '{}': frame at step {} lacks position, velocity, radius "
                                            "or mass", m.path, f.step));
  if (!f.box_lower || !f.box_length)
    throw std::invalid_argument(fmt::format("H5MD output '{}': frame at step {} lacks the box", m.path, f.step));
  const bool angular = f.angular_velocity != nullptr, orient = f.orientation != nullptr;
  if (m.frames == 0) {
    m.has_angular = angular;
    m.has_orientation = orient;
    m.has_image = f.image != nullptr;
  } else if (m.has_image && !f.image) {
    throw std::invalid_argument(fmt::format("H5MD output '{}': the frame at step {} lacks the periodic images the "
                                            "earlier frames have", m.path, f.step));
  } else if (angular != m.has_angular || orient != m.has_orientation) {
    // Rows must line up across elements, which the XDMF hyperslabs rely on.
    throw std::invalid_argument(fmt::format("H5MD output '{}': angular_velocity/orientation must be given in every "
                                            "frame or in none (step {})", m.path, f.step));
  }

  m.particle_element("position", f, f.position, m.dim);
  m.particle_element("velocity", f, f.velocity, m.dim);
  m.particle_element("radius", f, f.radius, 1);
  m.particle_element("mass", f, f.mass, 1);
  if (angular) m.particle_element("angular_velocity", f, f.angular_velocity, f.angular_components);
  if (orient) m.particle_element("orientation", f, f.orientation, f.orientation_components);
  if (m.has_image) m.image_element(f);
  m.box_element("edges", f, f.box_length);
  m.box_element("offset", f, f.box_lower);  // not in H5MD 1.1, which assumes the box starts at 0
  ++m.frames;
  m.max_count = std::max(m.max_count, f.count);
  if (m.xdmf) {
    if (m.frames == 1) m.register_xdmf_fields(angular, f.angular_components);
    if (f.count > 0) {
      write_xdmf_vertices(m.file.get(), m.max_count, m.path);
      write_xdmf_views(m.file.get(), m.xdmf_views, m.frames - 1, f.count, m.path);
    }
  }
  m.flush();   // the frame and its views on disk before the .xdmf names them

  if (m.xdmf) {
    m.xdmf->add_frame(m.frames - 1, f.time, f.count);
    m.update_xdmf(false);
  }
}

void H5mdWriter::write_observable(const std::string& name, long step, double time, double value) {
  impl_->record(impl_->observables.get(), "observables/", name, step, time, value);
}

void H5mdWriter::write_trace(const std::string& name, long step, double time, double value) {
  Impl& m = *impl_;
  if (!m.trace) m.trace = h5::create_group(m.grains.get(), "trace", m.path);
  m.record(m.trace.get(), "grains/trace/", name, step, time, value);
}

void H5mdWriter::Impl::record(hid_t parent, const std::string& where, const std::string& name, long step, double time,
                              double value) {
  Impl& m = *this;
  auto it = m.observable.find(where + name);
  if (it == m.observable.end()) {
    if (name.empty() || name == "." || name.find('/') != std::string::npos)
      throw std::invalid_argument(fmt::format("H5MD output '{}': invalid observable name '{}'", m.path, name));
    it = m.observable.emplace(where + name, m.make_series(parent, name, {}, 0)).first;
  }
  Series& s = it->second;
  if (step != m.record_step) {   // a new record: everything pending is whole records
    if (std::chrono::steady_clock::now() - m.last_flush >= kObservableFlushInterval) m.flush();
    m.record_step = step;
  }
  s.pending_step.push_back(step), s.pending_time.push_back(time), s.pending_value.push_back(value);
}

void H5mdWriter::write_warning(const std::string& text) {
  Impl& m = *impl_;
  const char* p = text.c_str();
  h5::Handle vstr = h5::vlen_string_type(m.path);
  h5::append_row(m.warnings.get(), vstr.get(), &p, {}, m.path, "/grains/warnings");
  m.flush();  // warnings are rare and often precede a crash
}

void H5mdWriter::set_attribute(const std::string& name, const std::string& value) {
  h5::attr_string(impl_->grains.get(), name, value, impl_->path);
}

void H5mdWriter::set_scalar(const std::string& name, double value) {
  h5::attr_double(impl_->grains.get(), name, value, impl_->path);
}

void H5mdWriter::write_table(const std::string& name, const std::vector<std::string>& columns,
                             const std::vector<double>& values) {
  Impl& m = *impl_;
  const std::string what = "/grains/" + name;
  if (H5Lexists(m.grains.get(), name.c_str(), H5P_DEFAULT) > 0)
    h5::check(H5Ldelete(m.grains.get(), name.c_str(), H5P_DEFAULT), m.path, "replacing " + what);
  const hsize_t dims[2] = {columns.empty() ? 0 : values.size() / columns.size(), columns.size()};
  h5::Handle space(h5::check(H5Screate_simple(2, dims, nullptr), m.path, what), H5Sclose);
  h5::Handle set(h5::check(H5Dcreate2(m.grains.get(), name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT,
                                      H5P_DEFAULT), m.path, "creating " + what),
                 H5Dclose);
  if (!values.empty())
    h5::check(H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), m.path, "writing " + what);
  h5::attr_strings(set.get(), "columns", columns, m.path);
  m.flush();
}

void H5mdWriter::flush() {
  impl_->update_xdmf(true);
  impl_->flush();
}

void H5mdWriter::write_checkpoint(const RunCheckpoint& cp) {
  Impl& m = *impl_;
  m.flush();   // every record up to `step` is in the file before a checkpoint names that step
  const hid_t g = m.grains.get();
  const auto valid = valid_checkpoint_slots(g, m.path);
  const int slot = valid.empty() ? 0 : 1 - valid.front().first;   // not the slot holding the newest
  const std::string name = checkpoint_slot_name(slot), what = "/grains/" + name;
  h5::Handle d = h5::exists(g, name, m.path) ? h5::open_dataset(g, name, m.path) : create_checkpoint_slot(g, slot, m.path);
  h5::attr_double(d.get(), "valid", 0, m.path);
  h5::check(H5Fflush(m.file.get(), H5F_SCOPE_GLOBAL), m.path, "flushing the file");
  h5::overwrite_bytes(d.get(), cp.state.data(), cp.state.size(), m.path, what);
  h5::attr_double(d.get(), "step", double(cp.step), m.path);   // exact: steps stay below 1e15 (Simulation::max_steps)
  h5::attr_double(d.get(), "time", cp.time, m.path);
  h5::attr_double(d.get(), "wall_seconds", cp.wall_seconds, m.path);
  h5::attr_double(d.get(), "cvode_seconds", cp.cvode_seconds, m.path);
  h5::attr_double(d.get(), "threads", cp.threads, m.path);
  h5::attr_string(d.get(), "gravity_kernels", cp.gravity_kernels, m.path);
  h5::attr_string(d.get(), "scene_check_sum", m.scene_check, m.path);
  h5::attr_double(d.get(), "stage", cp.stage, m.path);
  h5::attr_double(d.get(), "unreached", double(cp.unreached), m.path);
  h5::attr_doubles(d.get(), "stage_progress", cp.stage_progress, m.path);
  h5::attr_double(d.get(), "observables_at_step", cp.observables_at_step, m.path);
  h5::attr_double(d.get(), "frame_at_step", cp.frame_at_step, m.path);
  h5::attr_double(d.get(), "warnings", double(h5::shape(m.warnings.get(), m.path, "/grains/warnings").at(0)), m.path);
  h5::check(H5Fflush(m.file.get(), H5F_SCOPE_GLOBAL), m.path, "flushing the file");
  h5::attr_double(d.get(), "valid", 1, m.path);
  m.flush();
}

const std::string& H5mdWriter::path() const { return impl_->path; }
const std::string& H5mdWriter::xdmf_path() const { return impl_->xdmf_path; }

}  // namespace grains
