// Series kept apart from the observables (/grains/trace/<name>: grains consolidate's trace beside its stage records, at
// other steps than the frames): written, cut back and continued by a resume like the observables.
#include <catch2/catch.hpp>

#include <hdf5.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/h5md_checkpoint.hpp"
#include "io/h5md_writer.hpp"

using namespace grains;

namespace {

// The steps of the series at `series` (a path below the root).
std::vector<long long> steps_of(const std::string& path, const std::string& series) {
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(file >= 0);
  const hid_t d = H5Dopen2(file, ("/" + series + "/step").c_str(), H5P_DEFAULT);
  REQUIRE(d >= 0);
  const hid_t space = H5Dget_space(d);
  hsize_t rows = 0;
  H5Sget_simple_extent_dims(space, &rows, nullptr);
  std::vector<long long> steps(rows);
  if (rows) H5Dread(d, H5T_NATIVE_LLONG, H5S_ALL, H5S_ALL, H5P_DEFAULT, steps.data());
  H5Sclose(space), H5Dclose(d), H5Fclose(file);
  return steps;
}

}  // namespace

TEST_CASE("a trace is cut back and continued by a resume as the observables are", "[h5md]") {
  const std::string path = (std::filesystem::temp_directory_path() / "grains-h5md-trace.h5").string();
  RunCheckpoint checkpoint;
  checkpoint.state = std::vector<std::byte>(16, std::byte{3});
  {
    H5mdWriter out(path, 2, {true, true}, "test", "[scene]\n", false);
    out.write_observable("phi", 0, 0.0, 0.5);
    for (long step : {3L, 6L, 9L}) out.write_trace("phi", step, 0.1 * double(step), 0.4);
    checkpoint.step = 9;
    out.write_checkpoint(checkpoint);   // the records up to step 9 are the checkpoint's (observables_at_step)
    out.write_trace("phi", 12, 1.2, 0.45);   // after it: dropped by the resume
    out.write_observable("phi", 20, 2.0, 0.55);
    out.flush();
  }
  CHECK(steps_of(path, "grains/trace/phi") == std::vector<long long>{3, 6, 9, 12});
  {
    H5mdWriter out(path, read_checkpoint(path), false);
    out.write_trace("phi", 13, 1.3, 0.46);
    out.write_trace("z", 13, 1.3, 3.0);        // a new series in the group the file has
    out.flush();
  }
  CHECK(steps_of(path, "grains/trace/phi") == std::vector<long long>{3, 6, 9, 13});
  CHECK(steps_of(path, "grains/trace/z") == std::vector<long long>{13});
  CHECK(steps_of(path, "observables/phi") == std::vector<long long>{0});
  std::filesystem::remove(path);
}

TEST_CASE("an observable's or a trace's name is one name", "[h5md]") {
  const std::string path = (std::filesystem::temp_directory_path() / "grains-h5md-trace-names.h5").string();
  {
    H5mdWriter out(path, 2, {true, true}, "test", "[scene]\n", false);
    for (const char* bad : {"", ".", "a/b", "/x", "x/"}) {
      CHECK_THROWS_AS(out.write_observable(bad, 0, 0.0, 1.0), std::invalid_argument);
      CHECK_THROWS_AS(out.write_trace(bad, 0, 0.0, 1.0), std::invalid_argument);
    }
    out.write_trace("x", 0, 0.0, 1.0);
  }
  std::filesystem::remove(path);
}
