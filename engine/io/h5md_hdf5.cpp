// HDF5 C API helpers for the H5MD writer (see h5md_hdf5.hpp).
#include "io/h5md_hdf5.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "io/output_error.hpp"

namespace grains::h5 {

namespace {

// Collects the descriptions on HDF5's error stack, outermost (API call) first.
herr_t collect_error(unsigned, const H5E_error2_t* e, void* out) {
  if (e && e->desc && *e->desc) static_cast<std::vector<std::string>*>(out)->emplace_back(e->desc);
  return 0;
}

// HDF5's I/O errors spell out the whole call (time, file descriptor, buffer address, sizes) around the system's
// reason: "file write failed: time = ..., errno = 28, error message = 'No space left on device', buf = 0x...".
// Keeps what failed and the reason.
std::string without_call_details(const std::string& desc) {
  const std::string key = "error message = '";
  const auto at = desc.find(key);
  if (at == std::string::npos) return desc;
  const auto start = at + key.size(), end = desc.find('\'', start);
  return desc.substr(0, desc.find(':')) + ": " + desc.substr(start, end == std::string::npos ? end : end - start);
}

std::string hdf5_reason() {
  std::vector<std::string> descs;
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_error, &descs);
  H5Eclear2(H5E_DEFAULT);
  if (descs.empty()) return {};
  for (auto& d : descs) d = without_call_details(d);
  // The outermost says what failed, the innermost usually says why (e.g. "no such file").
  if (descs.size() == 1 || descs.front() == descs.back()) return descs.front();
  return descs.front() + ": " + descs.back();
}

Handle plist(hid_t cls, const std::string& file) {
  return Handle(check(H5Pcreate(cls), file, "creating a property list"), H5Pclose);
}

Handle simple_space(const std::vector<hsize_t>& dims, const std::vector<hsize_t>* max, const std::string& file) {
  hid_t id = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max ? max->data() : nullptr);
  return Handle(check(id, file, "creating a dataspace"), H5Sclose);
}

Handle scalar_space(const std::string& file) {
  return Handle(check(H5Screate(H5S_SCALAR), file, "creating a dataspace"), H5Sclose);
}

// Attributes cannot be overwritten in place with a different type or size, so replace them.
void drop_attribute(hid_t obj, const std::string& name, const std::string& file) {
  if (check(H5Aexists(obj, name.c_str()), file, "checking attribute " + name) > 0)
    check(H5Adelete(obj, name.c_str()), file, "replacing attribute " + name);
}

void write_attribute(hid_t obj, const std::string& name, hid_t type, const Handle& space, const void* data,
                     const std::string& file) {
  drop_attribute(obj, name, file);
  Handle a(check(H5Acreate2(obj, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT), file,
                 "creating attribute " + name),
           H5Aclose);
  check(H5Awrite(a.get(), type, data), file, "writing attribute " + name);
}

std::string describe_type(hid_t type) {
  switch (H5Tget_class(type)) {
    case H5T_INTEGER:
    case H5T_FLOAT:
      return fmt::format("{} of {} bytes, {} bits of precision at bit {}", H5Tget_class(type) == H5T_FLOAT ? "a float" : "an integer",
                         H5Tget_size(type), H5Tget_precision(type), H5Tget_offset(type));
    case H5T_STRING: return H5Tis_variable_str(type) > 0 ? "a variable-length string" : "a fixed-length string";
    default: return fmt::format("a type of class {} and {} bytes", int(H5Tget_class(type)), H5Tget_size(type));
  }
}

// A dataspace as messages give it: "a scalar", or its dimensions ("2 x 3").
std::string describe_space(hid_t space) {
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank <= 0) return rank == 0 ? "a scalar" : "an unreadable shape";
  std::vector<hsize_t> dims(std::size_t(rank), 0);
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return fmt::format("the shape {}", fmt::join(dims, " x "));
}

// The value of a scalar string of the stored `type`, which `read(memory type, buffer)` reads. Fixed length: read as
// stored, up to its first null. Variable length: a reference into the file's global heap, which HDF5 1.10.8 follows as
// it stands (one flipped bit of its object index crashes H5HG_read); grains writes none that it reads back, and
// reads those of older files.
template <class Read>
std::string read_string(hid_t type, hid_t space, Read read, const std::string& file, const std::string& what) {
  if (H5Tget_class(type) != H5T_STRING || H5Sget_simple_extent_npoints(space) != 1)
    throw std::runtime_error(fmt::format("H5MD output '{}': {} holds {} in {} place(s), where grains writes one string",
                                         file, what, describe_type(type), H5Sget_simple_extent_npoints(space)));
  if (H5Tis_variable_str(type) > 0) {
    Handle vlen = vlen_string_type(file);
    char* p = nullptr;
    check(read(vlen.get(), &p), file, "reading " + what);
    std::string value = p ? p : "";
    H5free_memory(p);
    return value;
  }
  std::string value(H5Tget_size(type), '\0');
  check(read(type, value.data()), file, "reading " + what);
  value.resize(std::strlen(value.c_str()));
  return value;
}

Handle fixed_string_type(std::size_t size, const std::string& file) {
  Handle t(check(H5Tcopy(H5T_C_S1), file, "creating a string type"), H5Tclose);
  check(H5Tset_size(t.get(), size == 0 ? 1 : size), file, "sizing a string type");
  check(H5Tset_strpad(t.get(), H5T_STR_NULLTERM), file, "padding a string type");
  check(H5Tset_cset(t.get(), H5T_CSET_UTF8), file, "setting a string charset");
  return t;
}

}  // namespace

Damaged::Damaged(const std::string& file, const std::string& defect)
    : std::runtime_error(fmt::format("H5MD output '{}': {}: the file is damaged and cannot be continued", file, defect)),
      defect(defect) {}

std::string defect_of(const std::exception& e) {
  const auto* damaged = dynamic_cast<const Damaged*>(&e);
  return damaged ? damaged->defect : e.what();
}

std::string path_of(hid_t parent, const std::string& name) {
  char where[512] = "";
  if (H5Iget_name(parent, where, sizeof where) <= 0) return name;
  const std::string at = where;
  return name.empty() || name == "." ? at : at == "/" ? "/" + name : at + "/" + name;
}

bool locked_by_another_process(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool locked = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);   // also releases the shared lock if it was taken
  return locked;
}

namespace {
// HDF5_USE_FILE_LOCKING as HDF5 reads it: FALSE or 0 turn its locks off (TRUE, 1 and BEST_EFFORT keep them).
bool hdf5_locks_files() {
  const char* v = std::getenv("HDF5_USE_FILE_LOCKING");
  return !v || !(std::strcmp(v, "FALSE") == 0 || std::strcmp(v, "0") == 0);
}
}  // namespace

WriterLock::WriterLock(const std::string& path) {
  if (hdf5_locks_files()) return;
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) return;   // the writer's own open names what is wrong with the file
  if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
  const bool held = errno == EWOULDBLOCK;
  release();
  if (held)
    throw std::runtime_error(fmt::format("'{}': another process is writing it (a run or a resume still going on); "
                                         "wait for it to end, or stop it first", path));
}

WriterLock& WriterLock::operator=(WriterLock&& o) noexcept {
  if (this != &o) { release(); fd_ = o.fd_; o.fd_ = -1; }
  return *this;
}

void WriterLock::release() {
  if (fd_ >= 0) ::close(fd_);   // closing the only descriptor of its open file releases the lock
  fd_ = -1;
}

void fail(const std::string& file, const std::string& what) {
  std::string reason = hdf5_reason();
  if (reason.empty()) throw OutputError(fmt::format("HDF5 output '{}': {} failed", file, what));
  throw OutputError(fmt::format("HDF5 output '{}': {} failed ({})", file, what, reason));
}

long long check(long long status, const std::string& file, const std::string& what) {
  if (status < 0) fail(file, what);
  return status;
}

Handle create_group(hid_t parent, const std::string& name, const std::string& file) {
  return Handle(check(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), file,
                      "creating group " + name),
                H5Gclose);
}

Handle open_or_create_group(hid_t parent, const std::string& name, const std::string& file) {
  return exists(parent, name, file) ? open_group(parent, name, file) : create_group(parent, name, file);
}

// Appended rows only ever touch the last chunk, so the chunk cache keeps two chunks. HDF5's default of 1 MB a dataset
// kept the chunks already written, and every flush (one a frame) walks every cached chunk of every dataset: a
// two-sphere run with a frame and a record every step took 0.39 ms a frame over its first 23,000 frames and
// 2.0 ms at 150,000.
Handle append_access(hid_t type, const std::vector<hsize_t>& chunk, const std::string& file) {
  std::size_t bytes = H5Tget_size(type);
  for (hsize_t n : chunk) bytes *= std::size_t(n);
  Handle dapl = plist(H5P_DATASET_ACCESS, file);
  check(H5Pset_chunk_cache(dapl.get(), 7, 2 * bytes, 1.0), file, "sizing a chunk cache");
  return dapl;
}

Handle create_extendable(hid_t parent, const std::string& name, hid_t type, const std::vector<hsize_t>& inner,
                         const std::vector<hsize_t>& chunk_inner, hsize_t chunk_rows, const std::string& file,
                         bool checksum) {
  std::vector<hsize_t> dims{0}, max{H5S_UNLIMITED}, chunk{chunk_rows < 1 ? 1 : chunk_rows};
  for (std::size_t i = 0; i < inner.size(); ++i) {
    dims.push_back(inner[i]);
    max.push_back(H5S_UNLIMITED);
    chunk.push_back(chunk_inner[i] < 1 ? 1 : chunk_inner[i]);
  }
  Handle space = simple_space(dims, &max, file);
  Handle dcpl = plist(H5P_DATASET_CREATE, file);
  check(H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()), file, "chunking " + name);
  if (checksum) check(H5Pset_fletcher32(dcpl.get()), file, "checksumming " + name);
  if (H5Tequal(type, H5T_NATIVE_DOUBLE) > 0) {
    // Slots of particles absent from a frame read as NaN rather than a plausible 0.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    check(H5Pset_fill_value(dcpl.get(), H5T_NATIVE_DOUBLE, &nan), file, "setting the fill value of " + name);
  }
  return Handle(check(H5Dcreate2(parent, name.c_str(), type, space.get(), H5P_DEFAULT, dcpl.get(),
                                 append_access(type, chunk, file).get()),
                      file, "creating dataset " + name),
                H5Dclose);
}

std::vector<hsize_t> shape(hid_t dataset, const std::string& file, const std::string& what) {
  Handle space(check(H5Dget_space(dataset), file, "reading the shape of " + what), H5Sclose);
  int rank = static_cast<int>(check(H5Sget_simple_extent_ndims(space.get()), file, "reading the rank of " + what));
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  check(H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr), file, "reading the shape of " + what);
  return dims;
}

void hard_link(hid_t from, const std::string& name, hid_t to, const std::string& as, const std::string& file) {
  check(H5Lcreate_hard(from, name.c_str(), to, as.c_str(), H5P_DEFAULT, H5P_DEFAULT), file, "linking " + as + " to " + name);
}

unsigned link_count(hid_t parent, const std::string& name, const std::string& file) {
#if H5_VERSION_GE(1, 12, 0)
  H5O_info2_t info;
  check(H5Oget_info_by_name3(parent, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT), file, "looking up " + name);
#else
  H5O_info_t info;
  check(H5Oget_info_by_name2(parent, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT), file, "looking up " + name);
#endif
  return info.rc;
}

std::string object_identity(hid_t object, const std::string& file, const std::string& what) {
#if H5_VERSION_GE(1, 12, 0)
  H5O_info2_t info;
  check(H5Oget_info3(object, &info, H5O_INFO_BASIC), file, "looking up " + what);
  return std::string(reinterpret_cast<const char*>(&info.token), sizeof info.token);
#else
  H5O_info_t info;
  check(H5Oget_info2(object, &info, H5O_INFO_BASIC), file, "looking up " + what);
  return std::string(reinterpret_cast<const char*>(&info.addr), sizeof info.addr);
#endif
}

void append_rows(hid_t dataset, hid_t mem_type, const void* data, hsize_t rows, const std::vector<hsize_t>& count,
                 const std::string& file, const std::string& what) {
  if (rows == 0) return;
  std::vector<hsize_t> dims = shape(dataset, file, what);
  if (dims.size() != count.size() + 1) fail(file, "appending to " + what + " (rank mismatch)");
  std::vector<hsize_t> start(dims.size(), 0), block{rows};
  start[0] = dims[0];
  dims[0] += rows;
  bool empty = false;
  for (std::size_t i = 0; i < count.size(); ++i) {
    if (count[i] > dims[i + 1]) dims[i + 1] = count[i];
    block.push_back(count[i]);
    empty = empty || count[i] == 0;
  }
  check(H5Dset_extent(dataset, dims.data()), file, "extending " + what);
  if (empty) return;  // a frame without particles still takes its row
  Handle fspace(check(H5Dget_space(dataset), file, "selecting in " + what), H5Sclose);
  check(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, block.data(), nullptr), file,
        "selecting in " + what);
  Handle mspace = simple_space(block, nullptr, file);
  check(H5Dwrite(dataset, mem_type, mspace.get(), fspace.get(), H5P_DEFAULT, data), file, "writing " + what);
}

Handle open_group(hid_t parent, const std::string& name, const std::string& file) {
  return Handle(check(H5Gopen2(parent, name.c_str(), H5P_DEFAULT), file, "opening group " + path_of(parent, name)), H5Gclose);
}

Handle open_extendable(hid_t parent, const std::string& name, const std::string& file) {
  hid_t type_id = -1;
  std::vector<hsize_t> chunk;
  {
    Handle d = open_dataset(parent, name, file);
    const std::string where = path_of(parent, name);
    type_id = check(H5Dget_type(d.get()), file, "reading the type of " + where);
    Handle dcpl(check(H5Dget_create_plist(d.get()), file, "reading the layout of " + where), H5Pclose);
    // Rows are appended to chunked datasets only (a contiguous one said "reading the chunks of value failed").
    if (H5Pget_layout(dcpl.get()) != H5D_CHUNKED) {
      H5Tclose(type_id);
      throw Damaged(file, fmt::format("{} is not stored in chunks, where grains writes a series in chunked rows to "
                                      "append to", where));
    }
    chunk.resize(H5S_MAX_RANK);
    chunk.resize(std::size_t(check(H5Pget_chunk(dcpl.get(), H5S_MAX_RANK, chunk.data()), file, "reading the chunks of " + where)));
  }
  Handle type(type_id, H5Tclose);
  return Handle(check(H5Dopen2(parent, name.c_str(), append_access(type.get(), chunk, file).get()), file,
                      "opening dataset " + path_of(parent, name)),
                H5Dclose);
}

Handle open_dataset(hid_t parent, const std::string& name, const std::string& file) {
  return Handle(check(H5Dopen2(parent, name.c_str(), H5P_DEFAULT), file, "opening dataset " + path_of(parent, name)),
                H5Dclose);
}

bool exists(hid_t parent, const std::string& name, const std::string& file) {
  return check(H5Lexists(parent, name.c_str(), H5P_DEFAULT), file, "looking up " + name) > 0;
}

void set_aside(hid_t parent, const std::string& name, const std::string& file, const std::string& what) {
  Handle object(check(H5Oopen(parent, name.c_str(), H5P_DEFAULT), file, what), H5Oclose);
  check(H5Oincr_refcount(object.get()), file, what);
  check(H5Ldelete(parent, name.c_str(), H5P_DEFAULT), file, what);
}

std::vector<std::string> link_names(hid_t group, const std::string& file, const std::string& what) {
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* name, const H5L_info_t*, void* out) -> herr_t {
    static_cast<std::vector<std::string>*>(out)->emplace_back(name);
    return 0;
  };
  check(H5Literate(group, H5_INDEX_NAME, H5_ITER_INC, nullptr, collect, &names), file, "listing " + what);
  return names;
}

// Found by tests/fuzz/corrupt_resume.py: one flipped bit made a chunk 1024 rows long 67,109,888 in the layout (the
// stored chunks stayed 1024 rows), and H5Dset_extent's pruning wrote past its buffer; one made a float's precision
// 2112 bits of its 64, or an integer's offset lie past its 8 bytes, and the conversion of a read or write wrote past
// its buffer. What the API reports of both is compared with what grains writes before the dataset is touched.
void check_as_written(hid_t dataset, hid_t type, hsize_t max_chunk_rows, const std::string& file, const std::string& what,
                      bool checksum) {
  const auto damaged = [&](const std::string& defect) {
    char name[512] = "";   // the dataset's path in the file, where HDF5 knows it
    const bool named = H5Iget_name(dataset, name, sizeof name) > 0;
    throw Damaged(file, fmt::format("{} {}", named ? name : what, defect));
  };
  Handle stored(check(H5Dget_type(dataset), file, "reading the type of " + what), H5Tclose);
  const bool vlen_string = H5Tget_class(type) == H5T_STRING && H5Tis_variable_str(type) > 0;
  if (vlen_string ? !(H5Tget_class(stored.get()) == H5T_STRING && H5Tis_variable_str(stored.get()) > 0)
                  : check(H5Tequal(stored.get(), type), file, "comparing the type of " + what) <= 0)
    damaged(fmt::format("has {}, where grains writes {}", describe_type(stored.get()), describe_type(type)));
  Handle dcpl(check(H5Dget_create_plist(dataset), file, "reading the layout of " + what), H5Pclose);
  const std::vector<hsize_t> dims = shape(dataset, file, what);
  std::vector<hsize_t> chunk(H5S_MAX_RANK);
  const int rank = H5Pget_layout(dcpl.get()) == H5D_CHUNKED ? H5Pget_chunk(dcpl.get(), H5S_MAX_RANK, chunk.data()) : -1;
  if (rank != int(dims.size()) || dims.empty())
    damaged(fmt::format("is not chunked as a dataset of rank {} (its chunks' rank: {}), where grains writes chunked rows",
                        dims.size(), rank));
  chunk.resize(std::size_t(rank));
  if (chunk[0] > max_chunk_rows) damaged(fmt::format("has chunks of {} rows, where grains writes at most {}", chunk[0], max_chunk_rows));
  // Every row grains writes takes bytes of the file (a frame's step and time at least), and so does a row's widest
  // value: a time's 6 rows made 1,152,921,504,606,846,982 by one flipped bit, or a box's 3 values 2,251,799,813,685,251,
  // had H5Dset_extent visit each of their chunks, a resume without end.
  hsize_t file_bytes = 0;
  {
    const Handle owner(check(H5Iget_file_id(dataset), file, "finding the file of " + what), H5Fclose);
    check(H5Fget_filesize(owner.get(), &file_bytes), file, "sizing the file");
  }
  if (*std::max_element(dims.begin(), dims.end()) > file_bytes)
    damaged(fmt::format("has a shape of {}, more than the file's {} bytes hold", fmt::join(dims, " x "), file_bytes));
#if H5_VERSION_GE(1, 10, 5)
  // Chunks are stored whole, with Fletcher-32's 4 bytes when checksummed: the first one's bytes are its dimensions'
  // (the layout's chunk, if intact). Other filters (a file repacked since) change them.
  const int filters = H5Pget_nfilters(dcpl.get());
  const bool fletcher32 =
      filters == 1 && H5Pget_filter2(dcpl.get(), 0, nullptr, nullptr, nullptr, 0, nullptr, nullptr) == H5Z_FILTER_FLETCHER32;
  if (!vlen_string && (checksum ? fletcher32 : filters == 0)) {
    Handle space(check(H5Dget_space(dataset), file, "reading the shape of " + what), H5Sclose);
    hsize_t chunks = 0;
    check(H5Dget_num_chunks(dataset, space.get(), &chunks), file, "counting the chunks of " + what);
    if (chunks > 0) {
      std::vector<hsize_t> offset(chunk.size());
      unsigned filters = 0;
      haddr_t address = 0;
      hsize_t bytes = 0;
      check(H5Dget_chunk_info(dataset, space.get(), 0, offset.data(), &filters, &address, &bytes), file,
            "reading the chunks of " + what);
      hsize_t expected = H5Tget_size(stored.get());
      for (hsize_t n : chunk) expected *= n;
      if (checksum) expected += 4;
      if (bytes != expected)
        damaged(fmt::format("has chunks of {} values ({} bytes) in its layout, but its first stored chunk holds {} bytes",
                            fmt::join(chunk, " x "), expected, bytes));
    }
  }
#endif
}

void truncate_rows(hid_t dataset, hsize_t rows, const std::string& file, const std::string& what) {
  std::vector<hsize_t> dims = shape(dataset, file, what);
  if (dims.empty() || dims[0] <= rows) return;
  dims[0] = rows;
  check(H5Dset_extent(dataset, dims.data()), file, "truncating " + what);
}

namespace {
template <class T>
std::vector<T> read_all(hid_t dataset, hid_t mem_type, const std::string& file, const std::string& what) {
  hsize_t n = 1;
  for (hsize_t d : shape(dataset, file, what)) n *= d;
  std::vector<T> values(n);
  if (n > 0) check(H5Dread(dataset, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), file, "reading " + what);
  return values;
}
}  // namespace

std::vector<long long> read_int64s(hid_t dataset, const std::string& file, const std::string& what) {
  return read_all<long long>(dataset, H5T_NATIVE_LLONG, file, what);
}

std::vector<double> read_doubles(hid_t dataset, const std::string& file, const std::string& what) {
  return read_all<double>(dataset, H5T_NATIVE_DOUBLE, file, what);
}

std::vector<double> read_row(hid_t dataset, hsize_t row, const std::string& file, const std::string& what) {
  std::vector<hsize_t> dims = shape(dataset, file, what), start(dims.size(), 0);
  if (dims.empty() || row >= dims[0]) fail(file, fmt::format("reading row {} of {}", row, what));
  start[0] = row, dims[0] = 1;
  hsize_t n = 1;
  for (hsize_t d : dims) n *= d;
  Handle fspace(check(H5Dget_space(dataset), file, "selecting in " + what), H5Sclose);
  check(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, dims.data(), nullptr), file,
        "selecting in " + what);
  Handle mspace = simple_space({n}, nullptr, file);
  std::vector<double> values(n);
  check(H5Dread(dataset, H5T_NATIVE_DOUBLE, mspace.get(), fspace.get(), H5P_DEFAULT, values.data()), file, "reading " + what);
  return values;
}

std::string read_dataset_string(hid_t parent, const std::string& name, const std::string& file) {
  Handle d = open_dataset(parent, name, file);
  Handle type(check(H5Dget_type(d.get()), file, "reading the type of dataset " + name), H5Tclose);
  Handle space(check(H5Dget_space(d.get()), file, "reading the shape of dataset " + name), H5Sclose);
  return read_string(type.get(), space.get(),
                     [&](hid_t memory, void* buffer) { return H5Dread(d.get(), memory, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer); },
                     file, "dataset " + name);
}

double read_attr_double(hid_t obj, const std::string& name, double fallback, const std::string& file) {
  if (check(H5Aexists(obj, name.c_str()), file, "looking up attribute " + name) <= 0) return fallback;
  Handle a(check(H5Aopen(obj, name.c_str(), H5P_DEFAULT), file, "opening attribute " + name), H5Aclose);
  // H5Aread writes every element: an array attribute where grains writes one number wrote past `value`.
  Handle type(check(H5Aget_type(a.get()), file, "reading the type of attribute " + name), H5Tclose);
  Handle space(check(H5Aget_space(a.get()), file, "reading the shape of attribute " + name), H5Sclose);
  const H5T_class_t kind = H5Tget_class(type.get());
  if ((kind != H5T_INTEGER && kind != H5T_FLOAT) || H5Sget_simple_extent_type(space.get()) != H5S_SCALAR)
    throw Damaged(file, fmt::format("attribute '{}' of {} holds {} in {}, where grains writes one number (a scalar)", name,
                                    path_of(obj, "."), describe_type(type.get()), describe_space(space.get())));
  double value = fallback;
  check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, &value), file, "reading attribute " + name);
  return value;
}

double read_attr_in(hid_t obj, const std::string& name, double fallback, double lo, double hi, bool whole,
                    const std::string& file) {
  if (check(H5Aexists(obj, name.c_str()), file, "looking up attribute " + name) <= 0) return fallback;
  const double value = read_attr_double(obj, name, fallback, file);
  if (std::isfinite(value) && value >= lo && value <= hi && (!whole || value == std::floor(value))) return value;
  throw Damaged(file, fmt::format("attribute '{}' of {} is {}, where grains writes {} in [{}, {}]", name, path_of(obj, "."),
                                  value, whole ? "a whole number" : "a number", lo, hi));
}

std::string read_attr_string(hid_t obj, const std::string& name, const std::string& fallback, const std::string& file) {
  if (check(H5Aexists(obj, name.c_str()), file, "looking up attribute " + name) <= 0) return fallback;
  Handle a(check(H5Aopen(obj, name.c_str(), H5P_DEFAULT), file, "opening attribute " + name), H5Aclose);
  Handle type(check(H5Aget_type(a.get()), file, "reading the type of attribute " + name), H5Tclose);
  Handle space(check(H5Aget_space(a.get()), file, "reading the shape of attribute " + name), H5Sclose);
  return read_string(type.get(), space.get(), [&](hid_t memory, void* buffer) { return H5Aread(a.get(), memory, buffer); },
                     file, "attribute " + name);
}

void overwrite_bytes(hid_t dataset, const void* data, hsize_t size, const std::string& file, const std::string& what) {
  check(H5Dset_extent(dataset, &size), file, "sizing " + what);
  if (size > 0) check(H5Dwrite(dataset, H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), file, "writing " + what);
}

void attr_string(hid_t obj, const std::string& name, const std::string& value, const std::string& file) {
  // Fixed length, in the object header: a variable-length string is a reference into the file's global heap, which
  // HDF5 1.10.8 follows as it reads it (see read_string). The object header holds an attribute of at most 64 KiB
  // (65,450 bytes of value went in, 65,480 did not): a longer value, a large scene, is variable length.
  constexpr std::size_t kMaxFixedBytes = 63 * 1024;
  if (value.size() < kMaxFixedBytes) return attr_fixed_string(obj, name, value, file);
  Handle type = vlen_string_type(file);
  const char* p = value.c_str();
  write_attribute(obj, name, type.get(), scalar_space(file), &p, file);
}

void attr_strings(hid_t obj, const std::string& name, const std::vector<std::string>& values,
                  const std::string& file) {
  // Fixed length, as H5MD readers expect for e.g. box/boundary.
  std::size_t width = 1;
  for (const auto& v : values) width = std::max(width, v.size() + 1);
  std::string packed(width * values.size(), '\0');
  for (std::size_t i = 0; i < values.size(); ++i) packed.replace(i * width, values[i].size(), values[i]);
  Handle type = fixed_string_type(width, file);
  write_attribute(obj, name, type.get(), simple_space({values.size()}, nullptr, file), packed.data(), file);
}

void attr_fixed_string(hid_t obj, const std::string& name, const std::string& value, const std::string& file) {
  // Scalar fixed-length, the form H5MD uses for author/creator names.
  Handle type = fixed_string_type(value.size() + 1, file);
  write_attribute(obj, name, type.get(), scalar_space(file), value.c_str(), file);
}

void attr_ints(hid_t obj, const std::string& name, const std::vector<int>& values, bool scalar,
               const std::string& file) {
  Handle space = scalar ? scalar_space(file) : simple_space({values.size()}, nullptr, file);
  write_attribute(obj, name, H5T_NATIVE_INT, space, values.data(), file);
}

void attr_double(hid_t obj, const std::string& name, double value, const std::string& file) {
  write_attribute(obj, name, H5T_NATIVE_DOUBLE, scalar_space(file), &value, file);
}

void attr_doubles(hid_t obj, const std::string& name, const std::vector<double>& values, const std::string& file) {
  if (values.empty()) return drop_attribute(obj, name, file);
  write_attribute(obj, name, H5T_NATIVE_DOUBLE, simple_space({values.size()}, nullptr, file), values.data(), file);
}

std::vector<double> read_attr_doubles(hid_t obj, const std::string& name, const std::string& file) {
  if (check(H5Aexists(obj, name.c_str()), file, "looking up attribute " + name) <= 0) return {};
  Handle a(check(H5Aopen(obj, name.c_str(), H5P_DEFAULT), file, "opening attribute " + name), H5Aclose);
  Handle space(check(H5Aget_space(a.get()), file, "reading the shape of attribute " + name), H5Sclose);
  std::vector<double> values(std::size_t(check(H5Sget_simple_extent_npoints(space.get()), file, "sizing attribute " + name)));
  if (!values.empty()) check(H5Aread(a.get(), H5T_NATIVE_DOUBLE, values.data()), file, "reading attribute " + name);
  return values;
}

Handle vlen_string_type(const std::string& file) {
  Handle t(check(H5Tcopy(H5T_C_S1), file, "creating a string type"), H5Tclose);
  check(H5Tset_size(t.get(), H5T_VARIABLE), file, "creating a string type");
  check(H5Tset_cset(t.get(), H5T_CSET_UTF8), file, "setting a string charset");
  return t;
}

void dataset_string(hid_t parent, const std::string& name, const std::string& value, const std::string& file) {
  // Fixed length: no reference into the global heap for a damaged file to crash HDF5's read with (see read_string).
  Handle type = fixed_string_type(value.size() + 1, file);
  Handle space = scalar_space(file);
  Handle d(check(H5Dcreate2(parent, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                 file, "creating dataset " + name),
           H5Dclose);
  check(H5Dwrite(d.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, value.c_str()), file, "writing dataset " + name);
}

}  // namespace grains::h5
