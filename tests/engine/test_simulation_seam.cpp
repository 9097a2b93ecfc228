// The Simulation seam: reading is side-effect free, time lands exactly, parameters are guarded.
#include <catch2/catch.hpp>

#include <cstring>

#include "core/byte_stream.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "packed_cell_scene.hpp"

using namespace grains;

namespace {
const char* small_gas = R"(
[scene]
dimension = 3
[particles]
layout = "lattice"
count = 125
solid_fraction = 0.3
velocity = "gaussian"
seed = 7
[contact]
restitution = 0.7
duration = 0.05
[friction]
coefficient = 0.4
[time]
dt = 0.001
[run]
threads = 2
)";
}

TEST_CASE("reading observables never changes the trajectory", "[seam]") {
  auto a = Simulation::create(Scene::from_string(small_gas, "gas"));
  auto b = Simulation::create(Scene::from_string(small_gas, "gas"));
  for (int k = 0; k < 40; ++k) {
    a->step_n(5);
    b->step_n(5);
    for (const auto& v : b->variables()) (void)b->get(v.name);   // b is read after every chunk, a never
    (void)b->particles();
  }
  CHECK(a->particles().position == b->particles().position);
  CHECK(a->particles().velocity == b->particles().velocity);
  CHECK(a->get("contacts") > 0);
}

TEST_CASE("step(duration) lands exactly on t + duration, also for a remainder", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step(0.0105);   // 10 whole steps and a half step
  CHECK(s->time() == 0.0105);
  CHECK(s->step_count() == 11);
  s->step(0.002);
  CHECK(s->time() == Approx(0.0125).epsilon(1e-15));
  CHECK_THROWS_AS(s->step(-1.0), SimulationError);
  // more steps than a step counter holds: refused, not one giant step (a host's doStep(1e17))
  CHECK_THROWS_WITH(s->step(1e17), Catch::Contains("1e+17") && Catch::Contains("at most 1e15 steps"));
  CHECK(s->step_count() == 13);   // unchanged by the refused call
}

TEST_CASE("the clock is the whole steps times dt, one rounding, not a sum that drifts", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  const double dt = s->dt();
  s->step_n(1000);   // a sum of 1000 dt = 0.001 is 1.0000000000000007
  CHECK(s->time() == 1000 * dt);
  s->step(0.0005);   // a remainder: the clock's new origin, exactly
  CHECK(s->time() == 1000 * dt + 0.0005);
  for (int k = 0; k < 10; ++k) s->step(100 * dt);
  CHECK(s->time() == (1000 * dt + 0.0005) + 1000 * dt);
  const auto saved = s->save_state();   // a restored clock goes on from the same origin
  s->step_n(7);
  const double after = s->time();
  s->restore_state(saved);
  s->step_n(7);
  CHECK(s->time() == after);
  CHECK(after == (1000 * dt + 0.0005) + 1007 * dt);
}

TEST_CASE("fixed parameters cannot be set and unknown names are named", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  CHECK(s->get("contact.restitution") == 0.7);
  CHECK_THROWS_WITH(s->set("contact.restitution", 0.5), Catch::Contains("contact.restitution") && Catch::Contains("fixed"));
  CHECK_THROWS_WITH(s->get("no_such_thing"), Catch::Contains("no_such_thing"));
}

TEST_CASE("save_state / restore_state continues bit-identically", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step_n(100);
  const auto saved = s->save_state();
  s->step_n(150);
  const auto reference = s->particles();
  s->restore_state(saved);
  CHECK(s->step_count() == 100);
  s->step_n(150);
  CHECK(s->particles().position == reference.position);
  CHECK(s->particles().angular_velocity == reference.angular_velocity);
  CHECK_THROWS_AS(s->restore_state(std::span(saved).first(saved.size() / 2)), SimulationError);
}

TEST_CASE("a saved vector whose count is corrupted is refused as truncated, and empty vectors read back", "[seam]") {
  ByteWriter w;
  w.put_vector(std::vector<double>{});
  w.put<std::uint64_t>(std::uint64_t(1) << 61);   // times sizeof(double) wraps to 0 bytes
  w.put(1.0);
  const auto bytes = w.take();
  ByteReader r(bytes);
  std::vector<double> empty{2.0}, corrupt;
  r.get_vector(empty);
  CHECK(empty.empty());
  CHECK_THROWS_WITH(r.get_vector(corrupt), Catch::Contains("truncated"));
}

TEST_CASE("a state saved by a build with another layout is refused by name, leaving the simulation as it was", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step_n(20);
  auto saved = s->save_state();
  s->step_n(5);
  const auto before = s->particles();
  // Builds before the format word began with the dimension: a 3D state's first four bytes held 3.
  std::vector<std::byte> old_layout(saved.begin() + 4, saved.end());
  REQUIRE_THROWS_WITH(s->restore_state(old_layout), Catch::Contains("format 0x3") && Catch::Contains("another version"));
  saved[0] = std::byte{0x01};   // a newer (or older) version of the word
  CHECK_THROWS_AS(s->restore_state(saved), SimulationError);
  CHECK(s->step_count() == 25);
  CHECK(s->particles().position == before.position);
}

TEST_CASE("a saved state with a changed byte is refused by its check sum, leaving the simulation as it was", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step_n(20);
  const auto saved = s->save_state();
  s->step_n(5);
  const auto before = s->particles();
  // One byte flipped anywhere after the format word: in the particles, the lists' indices, the springs, the sum.
  for (std::size_t at = 4; at < saved.size(); at += saved.size() / 97 + 1) {
    auto changed = saved;
    changed[at] ^= std::byte{0x10};
    REQUIRE_THROWS_WITH(s->restore_state(changed), Catch::Contains("check sum"));
  }
  CHECK_THROWS_WITH(s->restore_state(std::span(saved).first(saved.size() - 1)), Catch::Contains("check sum"));
  CHECK(s->step_count() == 25);
  s->step_n(5);   // and it runs on as if nothing had been tried
  auto t = Simulation::create(Scene::from_string(small_gas, "gas"));
  t->step_n(30);
  CHECK(s->particles().position == t->particles().position);
  CHECK(before.position != s->particles().position);
}

TEST_CASE("a saved neighbour list whose indices do not hold together is refused even under a valid check sum", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step_n(200);   // the lattice gas has pairs by then
  auto saved = s->save_state();
  const std::size_t N = s->particle_count();
  // Its layout: format, D, N, time, step, the clock's origin and whole steps, six vectors of 3-vectors,
  // the orientations and the periodic images (three 64-bit integers each), then the list's range, skin and
  // build count, then its row starts.
  const std::size_t at = 4 + 4 + 8 + 8 + 8 + 8 + 8 + 6 * (8 + N * 24) + (8 + N * 32) + (8 + N * 24) + 3 * 8;
  std::uint64_t rows;
  std::memcpy(&rows, saved.data() + at, 8);
  REQUIRE(rows == N + 1);
  const auto reseal = [](std::vector<std::byte> bytes) {   // a new check sum over the changed bytes
    const auto body = std::span(bytes).first(bytes.size() - 8);
    const std::uint64_t sum = check_sum(body);
    std::memcpy(bytes.data() + body.size(), &sum, 8);
    return bytes;
  };
  for (const std::uint32_t bad : {0x40000000u, 1u}) {   // past the pairs; a row ending before it starts
    auto changed = saved;
    std::memcpy(changed.data() + at + 8 + 4 * N, &bad, 4);   // the last row's end
    CHECK_THROWS_WITH(s->restore_state(reseal(changed)), Catch::Contains("neighbour list is inconsistent"));
  }
  {   // the first row's end far past the pairs, the next rows as they were (found by fuzzing: the first row was read
      // to that end, past the pairs' array, before the rows' order was checked)
    auto changed = saved;
    const std::uint32_t far = 0x40000000u;
    std::memcpy(changed.data() + at + 8 + 4, &far, 4);
    CHECK_THROWS_WITH(s->restore_state(reseal(changed)), Catch::Contains("rows out of order"));
  }
  std::uint64_t pairs;   // just after the row starts
  std::memcpy(&pairs, saved.data() + at + 8 + 4 * (N + 1), 8);
  REQUIRE(pairs > 0);
  std::uint32_t first_partner;
  std::memcpy(&first_partner, saved.data() + at + 8 + 4 * (N + 1) + 8, 4);
  REQUIRE(first_partner < N);
  const std::uint32_t beyond = std::uint32_t(N);
  std::memcpy(saved.data() + at + 8 + 4 * (N + 1) + 8, &beyond, 4);
  CHECK_THROWS_WITH(s->restore_state(reseal(saved)), Catch::Contains("neighbour list is inconsistent"));
  CHECK(s->step_count() == 200);
}

namespace {
std::vector<std::byte> resealed(std::vector<std::byte> bytes) {   // a new check sum over the changed bytes
  const auto body = std::span(bytes).first(bytes.size() - 8);
  const std::uint64_t sum = check_sum(body);
  std::memcpy(bytes.data() + body.size(), &sum, 8);
  return bytes;
}
}  // namespace

// Found by fuzzing (tests/fuzz/fuzz_state): unless the particle arrays' lengths are compared with the particle
// count, a state with a row too few is taken, and the next step reads past the array's end.
TEST_CASE("a saved state whose particle arrays have a row too few is refused even under a valid check sum", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step_n(20);
  const auto saved = s->save_state();
  const std::size_t N = s->particle_count();
  // After format, D, N, time, step and the clock's origin and whole steps: the positions' count, then their rows.
  const std::size_t at = 4 + 4 + 8 + 8 + 8 + 8 + 8;
  std::uint64_t rows;
  std::memcpy(&rows, saved.data() + at, 8);
  REQUIRE(rows == N);
  auto changed = saved;
  rows = N - 1;
  std::memcpy(changed.data() + at, &rows, 8);
  const auto last = changed.begin() + std::ptrdiff_t(at + 8 + (N - 1) * 24);
  changed.erase(last, last + 24);   // the last position's row
  CHECK_THROWS_WITH(s->restore_state(resealed(changed)), Catch::Contains("particle arrays have 124 rows, the scene 125"));
  CHECK(s->step_count() == 20);
  s->step_n(2);
}

// Found by fuzzing (tests/fuzz/fuzz_state): a restored position 1e19 cell lengths off overflowed the image count that
// wrapping it at the next step added up (undefined behaviour, which UBSan reported).
TEST_CASE("a saved position far outside the periodic cell is refused", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step_n(20);
  auto saved = s->save_state();
  const double far = 1e25;
  std::memcpy(saved.data() + 4 + 4 + 8 + 8 + 8 + 8 + 8 + 8, &far, 8);   // the first position's x
  CHECK_THROWS_WITH(s->restore_state(resealed(saved)), Catch::Contains("saved position of particle 0 is 1e+25 on axis 0"));
  CHECK(s->step_count() == 20);
}

// Found by fuzzing (tests/fuzz/fuzz_state): a restored velocity finite but huge moved a particle ~1e127 cell lengths
// in one step, and wrapping it at the next list build overflowed its image count (undefined behaviour).
TEST_CASE("a particle flung far beyond its periodic cell in one step stops the run with an error that names it", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  s->step_n(20);
  auto saved = s->save_state();
  const std::size_t N = s->particle_count();
  // After the positions' count and rows: the velocities' count, then their rows; particle 3's x.
  const std::size_t at = 4 + 4 + 8 + 8 + 8 + 8 + 8 + 8 + N * 24 + 8 + 3 * 24;
  double v;
  std::memcpy(&v, saved.data() + at, 8);
  REQUIRE(std::abs(v) < 10);
  v = 1e130;
  std::memcpy(saved.data() + at, &v, 8);
  s->restore_state(resealed(saved));   // a velocity is no error in itself
  CHECK_THROWS_WITH(s->step_n(1), Catch::Contains("particle 3 is") && Catch::Contains("cell lengths from the periodic cell on axis 0") &&
                                      Catch::Contains("1e+130"));
}

// Found by fuzzing (tests/fuzz/fuzz_state): a saved flag (the ramp's, the shell's, the barostat's) was read as a
// bool from whatever byte the state held, undefined behaviour for any byte but 0 and 1 (UBSan reported it).
TEST_CASE("a saved flag byte that is neither 0 nor 1 is refused", "[seam]") {
  // A ramped cell without contact damping: the ramp's on flag is the state's last byte before its check sum.
  auto s = Simulation::create(Scene::from_string(packed_cell_scene(2, 16, 0.01, "pressure_final = 0.1\nramp_duration = 1.0"), "ramp"));
  s->step_n(5);
  auto saved = s->save_state();
  std::byte& on = saved[saved.size() - 9];
  REQUIRE(on == std::byte{1});
  on = std::byte{2};
  CHECK_THROWS_WITH(s->restore_state(resealed(saved)), Catch::Contains("a flag that is neither 0 nor 1"));
  CHECK(s->step_count() == 5);
}

// Found by fuzzing (tests/fuzz/fuzz_state: a refused state left the barostat's restart flag set): restoring a state
// sets every control, and cell.active's setter released the held cell, which restarts CVODE at the next step, where
// the state's own barostat had no restart pending: a state saved with the cell active, restored while a host held it,
// did not continue as the run that saved it.
TEST_CASE("a state restored while the host holds the cell continues as the run that saved it", "[seam]") {
  const std::string scene = packed_cell_scene(2, 16, 0.01);
  auto s = Simulation::create(Scene::from_string(scene, "cell"));
  auto t = Simulation::create(Scene::from_string(scene, "cell"));
  s->step_n(30), t->step_n(30);
  const auto saved = s->save_state();
  s->set("cell.active", 0);
  s->step_n(3);
  s->restore_state(saved);
  REQUIRE(s->get("cell.active") == 1);
  s->step_n(40), t->step_n(40);
  CHECK(s->save_state() == t->save_state());
  CHECK(s->box().length == t->box().length);
}

TEST_CASE("step(k dt) takes exactly the k steps of step_n(k), also late in a run", "[seam]") {
  auto a = Simulation::create(Scene::from_string(small_gas, "gas"));
  auto b = Simulation::create(Scene::from_string(small_gas, "gas"));
  const double dt = a->dt();
  for (int chunk = 0; chunk < 30; ++chunk) {   // time accumulates rounding; no spurious remainder step
    a->step(7 * dt);
    b->step_n(7);
  }
  CHECK(a->step_count() == 210);
  CHECK(a->time() == b->time());
  CHECK(a->particles().position == b->particles().position);
  CHECK(a->get("kinetic_energy") == b->get("kinetic_energy"));
}

TEST_CASE("has(name) says whether index_of finds a variable of that name", "[seam]") {
  auto s = Simulation::create(Scene::from_string(small_gas, "gas"));
  for (const auto& v : s->variables()) CHECK(s->has(v.name));
  CHECK(s->has("contacts"));
  CHECK_FALSE(s->has("pressure_reduced"));   // a cell's output: this scene has no cell
  CHECK_THROWS_AS(s->index_of("pressure_reduced"), SimulationError);
  CHECK_FALSE(s->has(""));
}
