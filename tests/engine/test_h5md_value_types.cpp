// A resume checks each element's values against the type the writer creates it with (h5md_writer.cpp's value_type):
// it picked the type by the name alone, "image" integers, and refused an observable named "image" as damaged.
#include <catch2/catch.hpp>

#include <filesystem>
#include <string>
#include <vector>

#include "io/h5md_checkpoint.hpp"
#include "io/h5md_writer.hpp"

using namespace grains;

TEST_CASE("a resume checks each element against the type it was written with, whatever its name", "[h5md]") {
  const std::string path = (std::filesystem::temp_directory_path() / "grains-h5md-value-types.h5").string();
  const double position[2] = {0.5, 0.5}, velocity[2] = {0, 0}, radius = 0.1, mass = 1, lower[2] = {0, 0}, length[2] = {1, 1};
  const std::int64_t image[2] = {0, 0};
  H5mdFrame frame;
  frame.dimension = 2, frame.count = 1, frame.position = position, frame.velocity = velocity, frame.radius = &radius,
  frame.mass = &mass, frame.image = image, frame.box_lower = lower, frame.box_length = length;
  RunCheckpoint checkpoint;
  checkpoint.state = std::vector<std::byte>(16, std::byte{7});
  {
    H5mdWriter out(path, 2, {true, true}, "test", "[scene]\n", false);
    out.write_frame(frame);
    out.write_observable("image", 0, 0.0, 1.5);   // a double, whose name is the periodic images' element's
    out.write_checkpoint(checkpoint);
  }
  const RunCheckpoint resumed = read_checkpoint(path);
  CHECK(resumed.state == checkpoint.state);
  H5mdWriter out(path, resumed, false);   // refused before: "/observables/image/value has a float ..."
  frame.step = 1;
  out.write_frame(frame);
  out.write_observable("image", 1, 0.1, 2.5);
  std::filesystem::remove(path);
}
