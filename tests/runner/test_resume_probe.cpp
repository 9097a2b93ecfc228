// The child that reads a file before `grains resume` (runner/resume_probe.hpp), stuck on one object: the refusal names
// the object. A dataset whose values HDF5 reads from an external file that is a FIFO holds the child in open(2) as a
// header that makes HDF5 loop without end would, but without a damaged file to make.
#include <catch2/catch.hpp>

#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <sys/stat.h>
#include <unistd.h>

#include "io/h5md_hdf5.hpp"
#include "resume_probe.hpp"

using namespace grains;

TEST_CASE("the child stuck on one object past its limit is refused with the object named", "[resume]") {
  namespace fs = std::filesystem;
  const fs::path folder = fs::temp_directory_path() / ("grains-resume-probe-" + std::to_string(::getpid()));
  fs::create_directories(folder);
  const std::string file = (folder / "stuck.h5").string(), fifo = (folder / "values.fifo").string();
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  {
    h5::Handle f(H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    h5::Handle observables = h5::create_group(f.get(), "observables", file);
    h5::Handle series = h5::create_group(observables.get(), "stuck", file);
    h5::Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    REQUIRE(H5Pset_external(dcpl.get(), fifo.c_str(), 0, 8) >= 0);
    const hsize_t one = 1;
    h5::Handle space(H5Screate_simple(1, &one, nullptr), H5Sclose);
    h5::Handle steps(H5Dcreate2(series.get(), "step", H5T_STD_I64LE, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT),
                     H5Dclose);
    REQUIRE(steps.get() >= 0);
  }
  const auto start = std::chrono::steady_clock::now();
  try {
    refuse_a_file_hdf5_dies_reading(file, std::chrono::seconds(1));
    FAIL("the stuck child was not refused");
  } catch (const std::runtime_error& e) {
    CHECK(std::string(e.what()) == "'" + file + "': HDF5 was still reading /observables/stuck/step's values after 1 s (a "
                                   "damaged header can make it loop without end): the file is damaged; not resumed");
  }
  CHECK(std::chrono::steady_clock::now() - start < std::chrono::seconds(10));
  fs::remove_all(folder);
}
