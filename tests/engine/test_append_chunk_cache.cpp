// The H5MD writer's extendable datasets keep two chunks in their chunk cache, created (h5::create_extendable) or
// reopened to resume (h5::open_extendable). With HDF5's default of 1 MB a dataset every chunk already written stayed
// cached, and every flush (one a frame) walked them all: a two-sphere run with a frame and a record every step took
// 0.39 ms a frame over its first 23,000 frames and 2.0 ms at 150,000 (120,000 frames: 107 s, now 29 s). Run lengths
// that show the growth take minutes, so this checks the cache itself.
#include <catch2/catch.hpp>

#include <filesystem>

#include "io/h5md_hdf5.hpp"

using namespace grains;

namespace {

std::size_t cache_bytes(hid_t dataset) {
  h5::Handle dapl(H5Dget_access_plist(dataset), H5Pclose);
  std::size_t slots = 0, bytes = 0;
  double w0 = 0;
  REQUIRE(H5Pget_chunk_cache(dapl.get(), &slots, &bytes, &w0) >= 0);
  return bytes;
}

}  // namespace

TEST_CASE("extendable datasets cache two chunks, created and reopened", "[h5md]") {
  const std::string path = (std::filesystem::temp_directory_path() / "grains-append-cache.h5").string();
  {
    h5::Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    REQUIRE(file.get() >= 0);
    h5::Handle series = h5::create_extendable(file.get(), "series", H5T_IEEE_F64LE, {}, {}, 1024, path);
    h5::Handle frames = h5::create_extendable(file.get(), "frames", H5T_IEEE_F64LE, {2, 3}, {2, 3}, 1024, path);
    CHECK(cache_bytes(series.get()) == 2 * 1024 * 8);
    CHECK(cache_bytes(frames.get()) == 2 * 1024 * 6 * 8);
  }
  {
    h5::Handle file(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
    REQUIRE(file.get() >= 0);
    CHECK(cache_bytes(h5::open_extendable(file.get(), "series", path).get()) == 2 * 1024 * 8);
    CHECK(cache_bytes(h5::open_extendable(file.get(), "frames", path).get()) == 2 * 1024 * 6 * 8);
  }
  std::filesystem::remove(path);
}
