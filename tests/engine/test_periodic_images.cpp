// Periodic images: the view's wrapped positions plus image * cell length are the particles' unwrapped
// positions, continuous in time however often the particles cross the cell (also while the barostat moves
// it), and a saved state carries the images.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "polydisperse_particles.hpp"

using namespace grains;

namespace {

// A hot, nearly elastic gas of 324 disks in a cell some 30 diameters wide.
const std::string hot_gas = R"(
[scene]
dimension = 2
[particles]
layout = "lattice"
count = 324
solid_fraction = 0.3
velocity = "gaussian"
kinetic_energy = 6.0
seed = 11
[box]
periodic = true
[contact]
restitution = 0.98
duration = 0.05
[time]
[run]
threads = 1
)";

// The same kind of gas, squeezed by the barostat: the cell shrinks while the particles cross it.
std::string squeezed_gas() {
  return polydisperse_particles(2, 300, 0.3, 5, "velocity = \"gaussian\"\nkinetic_energy = 6.0") + R"(
[box]
periodic = true
[contact]
restitution = 0.98
duration = 0.05
[cell]
enabled = true
force_unit = 0
pressure = 2e-3
[time]
[run]
threads = 1
)";
}

std::vector<double> unwrapped(const Simulation& s) {
  const ParticleView p = s.particles();
  const BoxView b = s.box();
  REQUIRE(p.image.size() == p.position.size());
  std::vector<double> x(p.position.size());
  for (std::size_t k = 0; k < x.size(); ++k)
    x[k] = p.position[k] + double(p.image[k]) * b.length[k % std::size_t(p.dimension)];
  return x;
}

struct Crossings {
  long image_changes = 0;      // a particle's image changed on an axis from one step to the next
  long wrapped_jumps = 0;      // a particle's wrapped position moved by more than half the cell in one step
  double largest_move = 0;     // the unwrapped positions' largest move in a step, beyond the cell's affine flow
  double sum_mismatch = 0;     // |unwrapped move - sum of the steps' minimum-image moves| (fixed cell only)
  double relative_length_change = 0;
};

// Steps `s` one step at a time and compares, step by step, the unwrapped positions (wrapped + image * length)
// with the wrapped ones.
Crossings follow(Simulation& s, long steps) {
  const std::size_t D = std::size_t(s.dimension());
  Crossings c;
  const std::vector<double> first = unwrapped(s), first_length = s.box().length;
  std::vector<double> before = first, summed_moves(first.size(), 0.0);
  ParticleView was = s.particles();
  BoxView cell_was = s.box();
  for (long n = 0; n < steps; ++n) {
    s.step_n(1);
    const ParticleView p = s.particles();
    const BoxView cell = s.box();
    const std::vector<double> now = unwrapped(s);
    for (std::size_t k = 0; k < now.size(); ++k) {
      const std::size_t a = k % D;
      const double L = cell.length[a], flow = cell.length[a] / cell_was.length[a] - 1;
      double wrapped_move = p.position[k] - was.position[k];
      c.wrapped_jumps += std::abs(wrapped_move) > L / 2;
      c.image_changes += p.image[k] != was.image[k];
      summed_moves[k] += wrapped_move - L * std::round(wrapped_move / L);
      // The cell's flow carries a point at distance r from the lower corner by r * (dL / L).
      const double affine = std::abs(flow) * std::abs(before[k] - cell_was.lower[a]);
      c.largest_move = std::max(c.largest_move, std::abs(now[k] - before[k]) - affine);
    }
    before = now, was = p, cell_was = cell;
  }
  for (std::size_t k = 0; k < before.size(); ++k)
    c.sum_mismatch = std::max(c.sum_mismatch, std::abs((before[k] - first[k]) - summed_moves[k]));
  c.relative_length_change = std::abs(cell_was.length[0] / first_length[0] - 1);
  return c;
}

}  // namespace

TEST_CASE("wrapped position + image * length is continuous in a fixed periodic cell", "[images]") {
  auto s = Simulation::create(Scene::from_string(hot_gas, "hot gas"));
  const double L = s->box().length[0];
  const Crossings c = follow(*s, 60000);
  INFO("cell " << L << ", image changes " << c.image_changes << ", largest move " << c.largest_move << ", mismatch "
                << c.sum_mismatch);
  CHECK(c.image_changes > 3 * long(s->particle_count()));   // particles cross the boundary many times
  CHECK(c.wrapped_jumps == c.image_changes);   // each crossing is a jump of the wrapped position, the image's step
  CHECK(c.largest_move < 0.05);                // while the unwrapped positions move by the particles' own steps
  CHECK(c.sum_mismatch < 1e-9 * L);            // and by exactly the sum of those steps
}

TEST_CASE("wrapped position + image * length is continuous while the barostat moves the cell", "[images]") {
  auto s = Simulation::create(Scene::from_string(squeezed_gas(), "squeezed gas"));
  const Crossings c = follow(*s, 20000);
  INFO("length change " << c.relative_length_change << ", image changes " << c.image_changes << ", largest move "
                        << c.largest_move);
  CHECK(c.relative_length_change > 0.02);   // the cell moved
  CHECK(c.image_changes > long(s->particle_count()));
  CHECK(c.wrapped_jumps == c.image_changes);
  CHECK(c.largest_move < 0.05);
}

TEST_CASE("a saved state carries the periodic images, and the images are bookkeeping only", "[images][state]") {
  auto a = Simulation::create(Scene::from_string(hot_gas, "hot gas"));
  a->step_n(3000);
  const auto saved = a->save_state();
  const std::vector<std::int64_t> images_then = a->particles().image;
  long nonzero = 0;
  for (auto n : images_then) nonzero += n != 0;
  CHECK(nonzero > 0);
  a->step_n(2000);

  auto b = Simulation::create(Scene::from_string(hot_gas, "hot gas"));
  b->restore_state(saved);
  CHECK(b->particles().image == images_then);
  b->step_n(2000);
  CHECK(b->particles().image == a->particles().image);
  CHECK(b->particles().position == a->particles().position);
  CHECK(b->save_state() == a->save_state());
}

TEST_CASE("a box without a periodic axis gives no images", "[images]") {
  const std::string open_box = R"(
[scene]
dimension = 2
[particles]
layout = "lattice"
count = 16
solid_fraction = 0.3
[box]
periodic = false
[contact]
duration = 0.05
[run]
threads = 1
)";
  auto s = Simulation::create(Scene::from_string(open_box, "open box"));
  s->step_n(10);
  CHECK(s->particles().image.empty());
}
