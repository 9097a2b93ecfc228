// The choice of units: the same scene written with lengths, masses and times scaled by powers of two
// (exact in floating point, even exponents so that square roots stay exact) must run bit for bit the same,
// every length, velocity and force scaled. Any absolute constant in the engine (a tolerance, a pad, a
// threshold written in the default units) breaks this.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "neighbours/neighbour_list.hpp"

using namespace grains;

namespace {

// Scales: lengths L, masses M, times T.
struct Units {
  double L, M, T;
};
const Units base{1.0, 1.0, 1.0};
const Units small{std::ldexp(1.0, -40), std::ldexp(1.0, 20), std::ldexp(1.0, -30)};

// A dense cloud of spheres with random velocities, contacts (friction) and self-gravity in an open box:
// contacts from the first steps, so the pair loop's order of summation shows at once.
std::string cloud(const Units& u) {
  const double F = u.M * u.L / (u.T * u.T);
  return fmt::format(R"(
[scene]
dimension = 3
[particles]
layout = "random"
count = 300
size_distribution = "uniform"
diameter_min = {}
diameter_max = {}
mass = {}
velocity = "gaussian"
kinetic_energy = {}
seed = 3
[box]
periodic = false
lengths = [{}, {}, {}]
[contact]
restitution = 0.5
duration = {}
[friction]
coefficient = 0.5
[gravity]
enabled = true
G = {}
[time]
steps_per_contact = 30
[run]
threads = 1
)", 0.5 * u.L, 1.0 * u.L, 1.0 * u.M, 0.5 * F * u.L, 9.0 * u.L, 9.0 * u.L, 9.0 * u.L, 0.05 * u.T,
                     1.0 * u.L * u.L * u.L / (u.M * u.T * u.T));
}

void check_scaled(const Simulation& a, const Simulation& b, const Units& u) {
  const auto pa = a.particles(), pb = b.particles();
  REQUIRE(pa.count == pb.count);
  std::size_t position_differs = 0, velocity_differs = 0;
  for (std::size_t k = 0; k < pa.position.size(); ++k) {
    position_differs += pa.position[k] * u.L != pb.position[k];
    velocity_differs += pa.velocity[k] * (u.L / u.T) != pb.velocity[k];
  }
  CHECK(position_differs == 0);
  CHECK(velocity_differs == 0);
  CHECK(a.get("contacts") == b.get("contacts"));
  CHECK(a.get("neighbour_builds") == b.get("neighbour_builds"));
}

}  // namespace

TEST_CASE("a scene in units scaled by powers of two runs bit for bit the same", "[units]") {
  auto a = Simulation::create(Scene::from_string(cloud(base), "cloud"));
  auto b = Simulation::create(Scene::from_string(cloud(small), "cloud scaled"));
  REQUIRE(b->dt() == a->dt() * small.T);
  a->step_n(1500);
  b->step_n(1500);
  CHECK(a->get("contacts") > 10);
  check_scaled(*a, *b, small);
}

// The grid of an open box spans the particles, widened a little at the top: by 1e-9 (1 + |hi|) until
// 2026-12-05, an absolute pad that in units of 2^-40 was far wider than the cloud, so the grid had other
// cells and the list its pairs in another order (the forces then summed in another order).
TEST_CASE("the neighbour list of an open box lists a scaled configuration's pairs in the same order", "[units]") {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  Box<3> box;
  box.periodic = {false, false, false};
  std::vector<Vec<3>> x;
  std::vector<double> radius;
  for (int i = 0; i < 2000; ++i) {
    x.push_back(Vec<3>(-6 + 12 * u(rng), -6 + 12 * u(rng), -6 + 12 * u(rng)));
    radius.push_back(0.25 + 0.25 * u(rng));
  }
  const double scale = small.L;
  std::vector<Vec<3>> xs;
  std::vector<double> rs;
  for (const auto& p : x) xs.push_back(p * scale);
  for (double r : radius) rs.push_back(r * scale);
  NeighbourList<3> a, b;
  a.configure(0.0, 0.2);
  b.configure(0.0, 0.2 * scale);
  a.build(x, radius, box, 1);
  b.build(xs, rs, box, 1);
  REQUIRE(a.pair_count() > 1000);
  CHECK(a.start == b.start);
  CHECK(a.partner == b.partner);
}

// adhesion.range defaulted to 1e-3, a length in the scene's units: grains of a micrometre attracted across a
// thousand diameters, and the periodic box was refused as shorter than that reach. Now 1e-3 a, as in the paper.
TEST_CASE("the adhesion's default range is a thousandth of the grains' size, in any units", "[units]") {
  const auto scene = [](double L) {
    return fmt::format(R"(
[scene]
dimension = 2
[particles]
layout = "random"
count = 64
size_distribution = "uniform"
diameter_min = {}
diameter_max = {}
solid_fraction = 0.3
[contact]
overlap_limit = 0.5
[adhesion]
enabled = true
force = {}
stiffness = 1e5
[run]
threads = 1
)", 0.5 * L, 1.0 * L, 1.0 * L);
  };
  for (double L : {1.0, 1e-6, 1e3}) {
    INFO("lengths x " << L);
    auto s = Simulation::create(Scene::from_string(scene(L), "adhesive"));
    CHECK(s->get("adhesion.range") == 1e-3 * L);
  }
}
