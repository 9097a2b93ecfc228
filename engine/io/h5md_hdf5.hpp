// Thin helpers over the HDF5 C API used by the H5MD writer: owning handles, error translation,
// and extendable ("append a row") datasets. Internal to grains_output.
#pragma once
#include <hdf5.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace grains::h5 {

// Owns one HDF5 identifier and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer close) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = H5I_INVALID_HID; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) { reset(); id_ = o.id_; close_ = o.close_; o.id_ = H5I_INVALID_HID; }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }

  hid_t get() const { return id_; }
  explicit operator bool() const { return id_ >= 0; }
  void reset() { if (id_ >= 0 && close_) close_(id_); id_ = H5I_INVALID_HID; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  Closer close_ = nullptr;
};

// Whether another process holds HDF5's lock on the file (HDF5 takes it with flock(): exclusive while writing).
bool locked_by_another_process(const std::string& path);

// A writer's lock on its file where HDF5 takes none (HDF5_USE_FILE_LOCKING=FALSE, for file systems without
// locks): the same exclusive flock() HDF5 would hold, so that another run or resume of the file still finds
// it held (two resumes of one file both ran to "complete", with wrong velocities). Where HDF5 locks, or the file
// system has no locks, it holds nothing.
class WriterLock {
 public:
  WriterLock() = default;
  // Throws std::runtime_error naming `path` when another process holds the lock.
  explicit WriterLock(const std::string& path);
  WriterLock(WriterLock&& o) noexcept : fd_(o.fd_) { o.fd_ = -1; }
  WriterLock& operator=(WriterLock&& o) noexcept;
  WriterLock(const WriterLock&) = delete;
  WriterLock& operator=(const WriterLock&) = delete;
  ~WriterLock() { release(); }

 private:
  void release();
  int fd_ = -1;
};
// A file that is not as grains writes it: what() is "H5MD output '<file>': <defect>: the file is damaged and cannot be
// continued"; `defect` alone names the object and what is wrong with it, for a caller that passes the object over.
struct Damaged : std::runtime_error {
  Damaged(const std::string& file, const std::string& defect);
  std::string defect;
};
// What is wrong, for a message that names the file itself: a Damaged's defect, else the whole message.
std::string defect_of(const std::exception& e);

// The path of `name` in the object `parent` ("." : the object's own), as HDF5 names it, for messages: `name` alone
// where HDF5 knows no path.
std::string path_of(hid_t parent, const std::string& name);
// Throws OutputError (io/output_error.hpp) "HDF5 output <file>: <what> failed (<HDF5's own reason>)".
[[noreturn]] void fail(const std::string& file, const std::string& what);
// Returns `status` when it is non-negative, otherwise fail().
long long check(long long status, const std::string& file, const std::string& what);

Handle create_group(hid_t parent, const std::string& name, const std::string& file);
Handle open_or_create_group(hid_t parent, const std::string& name, const std::string& file);

// A dataset of shape [0, inner...] with the first axis unlimited (and the inner ones too, so the
// particle count may grow); chunked as [chunk_rows, chunk_inner...]. Doubles are filled with NaN.
// `checksum`: every chunk carries a Fletcher-32 checksum, and reading a damaged one fails.
Handle create_extendable(hid_t parent, const std::string& name, hid_t type, const std::vector<hsize_t>& inner,
                         const std::vector<hsize_t>& chunk_inner, hsize_t chunk_rows, const std::string& file,
                         bool checksum = false);
// Appends `rows` rows, each holding `count` (per inner axis) elements of `data`, growing inner axes if needed.
void append_rows(hid_t dataset, hid_t mem_type, const void* data, hsize_t rows, const std::vector<hsize_t>& count,
                 const std::string& file, const std::string& what);
inline void append_row(hid_t dataset, hid_t mem_type, const void* data, const std::vector<hsize_t>& count,
                       const std::string& file, const std::string& what) {
  append_rows(dataset, mem_type, data, 1, count, file, what);
}
// Current shape of a dataset.
std::vector<hsize_t> shape(hid_t dataset, const std::string& file, const std::string& what);
// A second name for the object `name` in `from`: `as` in `to` (an HDF5 hard link, the same dataset under both).
void hard_link(hid_t from, const std::string& name, hid_t to, const std::string& as, const std::string& file);
// How many hard links name the object `name` in `parent` (more than one: it is shared).
unsigned link_count(hid_t parent, const std::string& name, const std::string& file);

// What tells one object of the file from another (its address, or token), whatever links name it: two names of one
// dataset give the same.
std::string object_identity(hid_t object, const std::string& file, const std::string& what);

// Reading back (a resumed run): opening, truncating to the first `rows` rows, whole datasets and attributes.
Handle open_group(hid_t parent, const std::string& name, const std::string& file);
Handle open_dataset(hid_t parent, const std::string& name, const std::string& file);
// An extendable dataset (create_extendable's) opened to append rows: its chunk cache holds two chunks.
Handle open_extendable(hid_t parent, const std::string& name, const std::string& file);
// The access list of such a dataset: a chunk cache of two chunks of `chunk` (dimensions) values of `type`.
Handle append_access(hid_t type, const std::vector<hsize_t>& chunk, const std::string& file);
// Refuses a resumed dataset whose type or chunks are not what create_extendable made of `type` with at most
// `max_chunk_rows` rows a chunk (and `checksum`): HDF5 1.10.8 takes a damaged file's layout and type as they read and
// crashed on them.
void check_as_written(hid_t dataset, hid_t type, hsize_t max_chunk_rows, const std::string& file, const std::string& what,
                      bool checksum = false);
bool exists(hid_t parent, const std::string& name, const std::string& file);
// Unlinks the object `name` of `parent` without freeing it, its reference count raised first: HDF5 frees an object by
// decoding its header, which fails on a damaged one (after it has lowered the count). Its space stays unused in the file.
void set_aside(hid_t parent, const std::string& name, const std::string& file, const std::string& what);
// The names of a group's links, in name order (`what` names the group in the message of a failure).
std::vector<std::string> link_names(hid_t group, const std::string& file, const std::string& what);
void truncate_rows(hid_t dataset, hsize_t rows, const std::string& file, const std::string& what);
std::vector<long long> read_int64s(hid_t dataset, const std::string& file, const std::string& what);
std::vector<double> read_doubles(hid_t dataset, const std::string& file, const std::string& what);
// Row `row` (first axis) of a dataset of doubles, flattened.
std::vector<double> read_row(hid_t dataset, hsize_t row, const std::string& file, const std::string& what);
// A scalar string dataset's or attribute's value, fixed length (dataset_string's, attr_string's) or variable length
// (as older grains files hold them, and h5py writes a str).
std::string read_dataset_string(hid_t parent, const std::string& name, const std::string& file);
// An attribute's value, or `fallback` when the object has no such attribute. Anything but one number (a scalar of
// an integer or float type) is refused (std::runtime_error naming the object, the attribute and what it holds).
double read_attr_double(hid_t obj, const std::string& name, double fallback, const std::string& file);
// read_attr_double's value (`fallback` when absent), refused unless finite, within [lo, hi] and, with `whole`, a whole number: a count or a
// step converted from anything else is undefined (1e300 read as step -9223372036854775808).
double read_attr_in(hid_t obj, const std::string& name, double fallback, double lo, double hi, bool whole,
                    const std::string& file);
std::string read_attr_string(hid_t obj, const std::string& name, const std::string& fallback, const std::string& file);
// Replaces the whole content of a one-axis extendable byte dataset.
void overwrite_bytes(hid_t dataset, const void* data, hsize_t size, const std::string& file, const std::string& what);

// Attributes; an existing attribute of the same name is replaced.
// A scalar string: fixed length, but for a value longer than an attribute in the object header holds (a large scene).
void attr_string(hid_t obj, const std::string& name, const std::string& value, const std::string& file);
void attr_strings(hid_t obj, const std::string& name, const std::vector<std::string>& values,
                  const std::string& file);
void attr_fixed_string(hid_t obj, const std::string& name, const std::string& value, const std::string& file);
void attr_ints(hid_t obj, const std::string& name, const std::vector<int>& values, bool scalar,
               const std::string& file);
void attr_double(hid_t obj, const std::string& name, double value, const std::string& file);
// A one-axis array attribute; an empty one is removed (absent reads back as empty).
void attr_doubles(hid_t obj, const std::string& name, const std::vector<double>& values, const std::string& file);
std::vector<double> read_attr_doubles(hid_t obj, const std::string& name, const std::string& file);

// A scalar fixed-length UTF-8 string dataset.
void dataset_string(hid_t parent, const std::string& name, const std::string& value, const std::string& file);
// Variable-length UTF-8 string type (caller owns the handle).
Handle vlen_string_type(const std::string& file);

}  // namespace grains::h5
