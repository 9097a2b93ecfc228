// The strings a resume reads back (the scene, /grains' status and folders, the checkpoints' scene check sum) are fixed
// length, stored in place: as variable-length strings, references into the file's global heap, one flipped bit of a
// reference made HDF5 1.10.8 die in H5HG_read as grains read it. Those of files older grains wrote read as before.
#include <catch2/catch.hpp>

#include <filesystem>
#include <string>

#include "io/h5md_hdf5.hpp"

using namespace grains;

namespace {

bool variable_length(hid_t obj, const char* attribute) {
  h5::Handle a(H5Aopen(obj, attribute, H5P_DEFAULT), H5Aclose);
  h5::Handle type(H5Aget_type(a.get()), H5Tclose);
  return H5Tis_variable_str(type.get()) > 0;
}

}  // namespace

TEST_CASE("string attributes and the scene dataset are fixed length, and older files' variable-length ones read", "[h5md]") {
  const std::string path = (std::filesystem::temp_directory_path() / "grains-h5md-strings.h5").string();
  const std::string scene(200000, 'x'), long_value(64 * 1024, 'y');   // beyond what an object header holds
  {
    h5::Handle file(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    REQUIRE(file.get() >= 0);
    h5::attr_string(file.get(), "status", "running", path);
    h5::attr_string(file.get(), "empty", "", path);
    h5::attr_string(file.get(), "long", long_value, path);
    h5::dataset_string(file.get(), "scene.toml", scene, path);
    // as older grains files hold them
    h5::Handle vlen = h5::vlen_string_type(path);
    h5::Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    const char* old_value = "complete";
    h5::Handle a(H5Acreate2(file.get(), "old", vlen.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    REQUIRE(H5Awrite(a.get(), vlen.get(), &old_value) >= 0);
    h5::Handle d(H5Dcreate2(file.get(), "old.toml", vlen.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
    REQUIRE(H5Dwrite(d.get(), vlen.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, &old_value) >= 0);
  }
  h5::Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  REQUIRE(file.get() >= 0);
  CHECK_FALSE(variable_length(file.get(), "status"));
  CHECK_FALSE(variable_length(file.get(), "empty"));
  CHECK(variable_length(file.get(), "long"));
  {
    h5::Handle d(H5Dopen2(file.get(), "scene.toml", H5P_DEFAULT), H5Dclose);
    h5::Handle type(H5Dget_type(d.get()), H5Tclose);
    CHECK(H5Tis_variable_str(type.get()) == 0);
  }
  CHECK(h5::read_attr_string(file.get(), "status", "", path) == "running");
  CHECK(h5::read_attr_string(file.get(), "empty", "-", path) == "");
  CHECK(h5::read_attr_string(file.get(), "long", "", path) == long_value);
  CHECK(h5::read_attr_string(file.get(), "absent", "fallback", path) == "fallback");
  CHECK(h5::read_dataset_string(file.get(), "scene.toml", path) == scene);
  CHECK(h5::read_attr_string(file.get(), "old", "", path) == "complete");
  CHECK(h5::read_dataset_string(file.get(), "old.toml", path) == "complete");
  std::filesystem::remove(path);
}
