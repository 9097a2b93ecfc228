// The run's length (protocols/run_length.hpp): one of time.duration, time.steps, time.free_fall_times;
// two refused naming both (in the file or in two overrides); free-fall times only with self-gravity; an
// override replaces the file's.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include <fmt/format.h>

#include "cloud_scene.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "protocols/run_length.hpp"

using namespace grains;
using Catch::Contains;

namespace {

const CloudScene small_cloud{.count = 50, .seed = 3, .restitution = 0.5, .duration = 0.05, .threads = 1};
const std::string cloud = cloud_scene(small_cloud);

std::optional<long> steps_of(const std::string& text, const std::vector<std::string>& overrides = {}) {
  const Scene scene = Scene::from_string(text, "cloud.toml", overrides);
  return run_steps(scene, *Simulation::create(scene));
}

}  // namespace

TEST_CASE("run length: duration, steps or free-fall times", "[scene][run_length]") {
  CHECK_FALSE(steps_of(cloud).has_value());
  CHECK(steps_of(cloud + "[time]\nsteps = 123\n") == 123);
  const Scene scene = Scene::from_string(cloud, "cloud.toml");
  const auto sim = Simulation::create(scene);
  const double dt = sim->dt(), t_ff = sim->get("free_fall_time");
  CHECK(steps_of(cloud + "[time]\nduration = 2.0\n") == std::lround(2.0 / dt));
  CHECK(steps_of(cloud + "[time]\nfree_fall_times = 1.5\n") == std::lround(1.5 * t_ff / dt));
}

TEST_CASE("run length: two lengths are refused, an override replaces the file's", "[scene][run_length][errors]") {
  CHECK_THROWS_WITH(steps_of(cloud + "[time]\nduration = 2.0\nfree_fall_times = 1.0\n"),
                    Contains("time.free_fall_times") && Contains("given together with time.duration"));
  CHECK(steps_of(cloud + "[time]\nfree_fall_times = 1.0\n", {"time.steps=40"}) == 40);
  CHECK(steps_of(cloud + "[time]\nsteps = 40\n", {"time.free_fall_times=1.0"}).value() > 40);
  // two overrides of different lengths: refused naming both (not the last one silently winning)
  CHECK_THROWS_WITH(steps_of(cloud, {"time.steps=100", "time.duration=0.01"}),
                    Contains("--set time.duration") && Contains("given together with --set time.steps"));
  // the same key twice with two values: refused too (the last one won), as test_set_given_twice.cpp says
  CHECK_THROWS_WITH(steps_of(cloud, {"time.steps=100", "time.steps=50"}), Contains("--set time.steps: given twice"));
  // a length beyond the step counter (it once ran 0 steps) names the key, its steps and the limit
  CHECK_THROWS_WITH(steps_of(cloud + "[time]\nduration = 1e17\n"),
                    Contains("time.duration") && Contains("value 1e+17") && Contains("at most 1e+15 steps"));
}

TEST_CASE("run length: free-fall times need self-gravity", "[scene][run_length][errors]") {
  CloudScene no_gravity = small_cloud;
  no_gravity.gravity = false;
  CHECK_THROWS_WITH(steps_of(cloud_scene(no_gravity) + "[time]\nfree_fall_times = 3.0\n"),
                    Contains("time.free_fall_times") && Contains("gravity.enabled = true"));
}

TEST_CASE("run length: free-fall times of a cloud without a free-fall time are refused", "[scene][run_length][errors]") {
  // One particle: R0 = 0, t_ff = 0; the run took 0 steps, its outputs NaN, and exited 0.
  CloudScene one = small_cloud;
  one.count = 1, one.edge = 10;
  CHECK_THROWS_WITH(steps_of(cloud_scene(one) + "[time]\nfree_fall_times = 3.0\n"),
                    Contains("time.free_fall_times: value 3") && Contains("1 particle(s) has none") &&
                        Contains("give time.steps or time.duration instead"));
  CHECK(steps_of(cloud_scene(one) + "[time]\nsteps = 10\n") == 10);
}

TEST_CASE("run length: a duration that rounds to no step is refused", "[scene][run_length][errors]") {
  // time.duration below half a step ran 0 steps without a word (grains check said "takes 0 steps").
  const Scene scene = Scene::from_string(cloud, "cloud.toml");
  const double dt = Simulation::create(scene)->dt();
  CHECK_THROWS_WITH(steps_of(cloud, {fmt::format("time.duration={}", 0.4 * dt)}),
                    Contains("time.duration: value") && Contains("which rounds to none") &&
                        Contains("at least half a step"));
  // counted in free-fall times, the bound is given in them too (and in time)
  const double t_ff = Simulation::create(scene)->get("free_fall_time");
  CHECK_THROWS_WITH(steps_of(cloud, {"time.free_fall_times=1e-9"}),
                    Contains("time.free_fall_times: value 1e-09") &&
                        Contains(fmt::format("allowed at least half a step, {:.6g} ({:.6g} in time)", 0.5 * dt / t_ff, 0.5 * dt)));
  CHECK(steps_of(cloud, {fmt::format("time.duration={}", 0.6 * dt)}) == 1);
  CHECK(steps_of(cloud, {"time.steps=0"}) == 0);   // zero steps asked for in steps is a choice: the initial state
}
