// The softened core (core/softened_core.hpp): the largest mass within the softening length of one grain, and the
// check that warns when the step cannot resolve the orbits inside it (physics.md section 3: nothing blows up
// silently), which the start-up's two-grain orbit rule cannot foresee.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "core/softened_core.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"

using namespace grains;
using Catch::Matchers::Contains;

namespace {

// Every pair measured: the reference the grid must reproduce.
template <int D>
SoftenedCore every_pair(const std::vector<Vec<D>>& x, const std::vector<double>& m, double reach) {
  SoftenedCore best;
  for (std::size_t i = 0; i < x.size(); ++i) {
    double mass = 0;
    std::size_t count = 0;
    for (std::size_t j = 0; j < x.size(); ++j)
      if ((x[j] - x[i]).norm() < reach) mass += m[j], ++count;
    if (count > 1 && mass > best.mass) best = {mass, count, i};
  }
  return best;
}

template <int D>
void check_against_every_pair(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), w(0.5, 2);
  std::vector<Vec<D>> x;
  std::vector<double> m;
  for (int i = 0; i < 400; ++i) {   // a thin gas, and a tight clump astride cell boundaries (the grid's edge is 0.1)
    Vec<D> p;
    for (int a = 0; a < D; ++a) p[a] = i < 300 ? 3 * u(rng) : 0.03 * u(rng);
    x.push_back(p), m.push_back(w(rng));
  }
  const SoftenedCore grid = densest_softened_core<D>(x, m, 0.1), reference = every_pair<D>(x, m, 0.1);
  CHECK(grid.mass == Approx(reference.mass).epsilon(1e-12));
  CHECK(grid.count == reference.count);
  double at_centre = 0;   // the centre it names holds that mass (several may, to rounding: every clump member here)
  for (std::size_t j = 0; j < x.size(); ++j)
    if ((x[j] - x[grid.centre]).norm() < 0.1) at_centre += m[j];
  CHECK(at_centre == Approx(reference.mass).epsilon(1e-12));
  CHECK(grid.count >= 100);   // the clump is all within reach of its members
}

// The map of vectors the check used before its flat table (i ascending, the 3^D cells in turn, j ascending in each,
// each pair added to both sums): the order of every sum's terms, which the flat table must keep bit for bit (the
// check's warning quotes the core's mass to six digits, and a run's warnings must not move with the grid).
template <int D>
SoftenedCore map_of_vectors(const std::vector<Vec<D>>& x, const std::vector<double>& m, double reach) {
  using Cell = std::array<std::int64_t, D>;
  std::vector<double> within(m);
  std::vector<std::size_t> count(x.size(), 1);
  auto cell_of = [&](const Vec<D>& p) {
    Cell c;
    for (int a = 0; a < D; ++a) c[a] = std::int64_t(std::floor(p[a] / reach));
    return c;
  };
  std::map<Cell, std::vector<std::size_t>> cells;
  for (std::size_t i = 0; i < x.size(); ++i) cells[cell_of(x[i])].push_back(i);
  for (std::size_t i = 0; i < x.size(); ++i)
    for (int k = 0; k < (D == 3 ? 27 : 9); ++k) {
      Cell c = cell_of(x[i]);
      for (int a = 0, rest = k; a < D; ++a, rest /= 3) c[a] += rest % 3 - 1;
      if (const auto f = cells.find(c); f != cells.end())
        for (const std::size_t j : f->second)
          if (j > i && (x[j] - x[i]).squaredNorm() < reach * reach) within[i] += m[j], within[j] += m[i], ++count[i], ++count[j];
    }
  SoftenedCore best;
  for (std::size_t i = 0; i < x.size(); ++i)
    if (count[i] > 1 && within[i] > best.mass) best = {within[i], count[i], i};
  return best;
}

template <int D>
void check_against_map_of_vectors(unsigned seed, double spread) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::lognormal_distribution<double> w(0, 1);   // masses over decades: sums in another order differ in their last bits
  std::vector<Vec<D>> x;
  std::vector<double> m;
  for (int i = 0; i < 3000; ++i) {
    Vec<D> p;
    for (int a = 0; a < D; ++a) p[a] = spread * u(rng);
    x.push_back(p), m.push_back(w(rng));
  }
  const SoftenedCore grid = densest_softened_core<D>(x, m, 0.1), reference = map_of_vectors<D>(x, m, 0.1);
  CHECK(grid.mass == reference.mass);   // the same bits
  CHECK(grid.count == reference.count);
  CHECK(grid.centre == reference.centre);
  CHECK(grid.count >= 2);
}

// Unit grains of one diameter at `positions` (TOML), at rest, no contacts, G = 1, eps = softening R_min = R.
std::string resting_grains(const std::string& positions, double diameter, double dt) {
  return fmt::format(R"(
[particles]
layout = "list"
positions = {}
diameter = {:.17g}
mass = 1.0
[box]
periodic = false
[contact]
enabled = false
[gravity]
enabled = true
G = 1.0
softening = 1.0
[time]
dt = {:.17g}
[run]
threads = 1
)", positions, diameter, dt);
}

// Six unit grains of diameter 0.1 (R_min = 0.05, eps = 0.05), the `spread` of their positions. The start-up rule's
// orbit is two grains' at d = 0: T_orb = 2 pi sqrt(eps^3 / (2 G)).
std::string six_grains(double spread, double dt) {
  return resting_grains(fmt::format("[[0, 0, 0], [{0}, 0, 0], [0, {0}, 0], [0, 0, {0}], [-{0}, 0, 0], [0, -{0}, 0]]", spread),
                        0.1, dt);
}

long warnings_starting(const Simulation& sim, const std::string& start) {
  return std::count_if(sim.warnings().begin(), sim.warnings().end(), [&](const std::string& w) { return w.starts_with(start); });
}
long core_warnings(const Simulation& sim) { return warnings_starting(sim, "softened-core check"); }

// What a host does to steer gravity between steps (the FMU sets the tunable parameter through the same call).
void set_G(Simulation& sim, double G) { sim.set(sim.index_of("gravity.G"), G); }

}  // namespace

TEST_CASE("softened core: the grid finds the densest core that every pair measured finds", "[gravity][core]") {
  check_against_every_pair<3>(1);
  check_against_every_pair<3>(2);
  check_against_every_pair<2>(3);
  CHECK(densest_softened_core<3>({}, {}, 0.1).mass == 0);
  // Grains farther apart than the reach: no core.
  const SoftenedCore alone = densest_softened_core<2>({Vec<2>(0, 0), Vec<2>(1, 0), Vec<2>(0, 1)}, {1.0, 3.0, 2.0}, 0.5);
  CHECK(alone.mass == 0);
  CHECK(alone.count == 0);
  // A lone grain heavier than a crowded pair does not hide it (it was the "core", of one grain, and the check stopped).
  const SoftenedCore pair = densest_softened_core<2>({Vec<2>(0, 0), Vec<2>(5, 0), Vec<2>(5.01, 0)}, {3.0, 1.0, 1.0}, 0.05);
  CHECK(pair.mass == 2.0);
  CHECK(pair.count == 2);
  CHECK((pair.centre == 1 || pair.centre == 2));
}

TEST_CASE("softened core: the flat table sums every core's masses in the order the map of vectors did", "[gravity][core]") {
  for (const double spread : {0.2, 1.0, 4.0}) {   // one crowded core, clumps over many cells, a thin gas
    check_against_map_of_vectors<3>(3, spread);
    check_against_map_of_vectors<2>(4, spread / 4);
  }
}

TEST_CASE("softened-core check: a step too coarse for the orbits in a core of six grains is warned about, once",
          "[gravity][core]") {
  const double pi = std::acos(-1.0), eps = 0.05;
  const double pair_step = 2 * pi * std::sqrt(eps * eps * eps / 2) / 20, core_step = 2 * pi * std::sqrt(eps * eps * eps / 6) / 20;
  // Between the two: the start-up rule (two grains) is content, the six within eps of each other are not.
  const double dt = 0.8 * pair_step;
  REQUIRE(dt > core_step);
  auto sim = Simulation::create(Scene::from_string(six_grains(0.02, dt), "core"));
  REQUIRE(sim->warnings().empty());
  sim->get("kinetic_energy");   // the outputs computed: where the check runs
  REQUIRE(core_warnings(*sim) == 1);
  CHECK_THAT(sim->warnings().back(),
             Contains("softened-core check: at t = 0 ") && Contains("6 grains of mass 6 lie within the softening length eps = 0.05") &&
                 Contains(fmt::format("exceeds T / 20 = {:.6g}", core_step)) &&
                 Contains(fmt::format("asks time.dt <= {:.6g} at G = 1", pair_step)));
  // Once: more steps, read again, add none; nor does a simulation restored from its state.
  sim->step_n(5);
  sim->get("kinetic_energy");
  CHECK(core_warnings(*sim) == 1);
  auto restored = Simulation::create(Scene::from_string(six_grains(0.02, dt), "core"));
  restored->restore_state(sim->save_state());
  restored->get("kinetic_energy");
  CHECK(core_warnings(*restored) == 0);
  // A step within the core's T / 20 is content; so is the coarse one for grains spread beyond eps of each other.
  auto fine = Simulation::create(Scene::from_string(six_grains(0.02, 0.9 * core_step), "fine"));
  fine->get("kinetic_energy");
  CHECK(fine->warnings().empty());
  auto spread = Simulation::create(Scene::from_string(six_grains(0.2, dt), "spread"));
  spread->get("kinetic_energy");
  CHECK(spread->warnings().empty());
}

TEST_CASE("softened-core check: the aggregation scene at k* = 10 warns of a core the start-up rule did not foresee",
          "[gravity][core]") {
  // The sweep's k* = 10, zeta = 0.02 point at the sweep's 30 steps per contact, read every 8 steps as its runs are:
  // the start-up rule warns of two grains' orbit; three grains lie within eps of each other at 0.67 t_ff (step 152).
  auto soft = Simulation::create(Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/aggregation.toml",
                                                  {"run.threads=1", "contact.restitution=0.9390895628611485",
                                                   "contact.duration=0.49682878898616584"}));
  for (int k = 0; k < 27; ++k) soft->step_n(8), soft->get("kinetic_energy");
  REQUIRE(core_warnings(*soft) == 1);
  const std::string& w = *std::find_if(soft->warnings().begin(), soft->warnings().end(),
                                       [](const std::string& x) { return x.starts_with("softened-core check"); });
  CHECK_THAT(w, Contains("grains of mass") && Contains("time.steps_per_contact") &&
                    Contains("should every grain sink into it"));
}

TEST_CASE("softened-core check: two grains within eps, the start-up rule's own pair, are not warned about twice",
          "[gravity][core]") {
  // R_min = 0.131 (eps = 0.131): pow(eps^2, 1.5), the start-up rule's, exceeds eps^3 by a rounding, and the core check,
  // which wrote eps^3, found the pair's orbit step a bit below the start-up rule's and warned of it again.
  const double pi = std::acos(-1.0), eps = 0.131, pair_step = 2 * pi * std::sqrt(std::pow(eps * eps, 1.5) / 2) / 20;
  auto sim = Simulation::create(Scene::from_string(resting_grains("[[0, 0, 0], [0.05, 0, 0]]", 0.262, 1.5 * pair_step), "pair"));
  REQUIRE(sim->warnings().size() == 1);
  REQUIRE_THAT(sim->warnings()[0], Contains("exceeds T_orb / 20"));
  sim->get("kinetic_energy");
  CHECK(core_warnings(*sim) == 0);
}

TEST_CASE("softened-core check: after a host raises G, it compares with the orbit rule at that G and quotes its step",
          "[gravity][core]") {
  const double pi = std::acos(-1.0), eps = 0.05;
  const auto pair_step = [&](double G) { return 2 * pi * std::sqrt(eps * eps * eps / (2 * G)) / 20; };
  const auto core_step = [&](double G) { return 2 * pi * std::sqrt(eps * eps * eps / (6 * G)) / 20; };
  // Within the six grains' T / 20 at G = 1; at G = 2 beyond it, and still within the orbit rule's (two grains).
  const double dt = 0.9 * core_step(1);
  REQUIRE(dt > core_step(2));
  REQUIRE(dt < pair_step(2));
  auto sim = Simulation::create(Scene::from_string(six_grains(0.02, dt), "core"));
  sim->get("kinetic_energy");
  REQUIRE(sim->warnings().empty());
  set_G(*sim, 2.0);
  sim->get("kinetic_energy");
  REQUIRE(sim->warnings().size() == 1);   // the core's, and no orbit-rule warning: the step is within the rule at G = 2
  CHECK_THAT(sim->warnings().back(),
             Contains("softened-core check") && Contains(fmt::format("exceeds T / 20 = {:.6g}", core_step(2))) &&
                 Contains(fmt::format("asks time.dt <= {:.6g} at G = 2", pair_step(2))));
}

// Two unit grains of diameter 1 (R_min = 0.5), 1.25 apart: within eps = 4 R_min = 2, not touching. Elastic contacts of
// t_c = 1 (k_n = m* pi^2 / t_c^2 = 4.93, capped at k_n 0.1 R_min = 0.247), 25 steps each.
std::string two_grains_with_contacts(double G) {
  return fmt::format(R"(
[particles]
layout = "list"
positions = [[0, 0, 0], [1.25, 0, 0]]
diameter = 1.0
mass = 1.0
[box]
periodic = false
[contact]
enabled = true
duration = 1.0
restitution = 1.0
[gravity]
enabled = true
G = {:.17g}
softening = 4.0
[time]
dt = 0.04
[run]
threads = 1
)", G);
}

TEST_CASE("orbit rule: a host's G moves its step and whether contacts hold grains apart, and a G it exceeds is warned of once",
          "[gravity][core]") {
  // The rule's pull on a grain, G m_max M / (2 R_min)^2 = 2 G, against the capped force 0.247: held (d = 2 R_min = 1)
  // below G = 0.12, not above (d = 0). Its step at d = 0 is 2 pi sqrt(eps^3 / (2 G)) / 20 = 0.628 / sqrt(G), and the
  // pair, within eps, is a core of the same two grains with the same step: at d = 0 the rule has said all there is.
  const double pi = std::acos(-1.0);
  const auto step_at = [&](double G, double d) { return 2 * pi * std::sqrt(std::pow(d * d + 4, 1.5) / (2 * G)) / 20; };
  auto sim = Simulation::create(Scene::from_string(two_grains_with_contacts(0.05), "pair"));
  sim->get("kinetic_energy");
  REQUIRE(sim->warnings().empty());
  // G = 4: held no longer, and the step (0.04) within the rule's at d = 0, 0.314.
  set_G(*sim, 4.0);
  sim->get("kinetic_energy");
  CHECK(sim->warnings().empty());
  // G = 500: 0.04 exceeds the rule's step at d = 0, 0.0281 (at d = 2 R_min it would be 0.0332, where the core's 0.0281
  // would ask a finer step than the rule and be warned of as a core instead).
  REQUIRE(0.04 > step_at(500, 0));
  set_G(*sim, 500.0);
  sim->get("kinetic_energy");
  REQUIRE(sim->warnings().size() == 1);
  CHECK(core_warnings(*sim) == 0);
  CHECK_THAT(sim->warnings()[0],
             Contains("gravity.G = 500 (set at t = 0, step 0): time.dt = 0.04 exceeds T_orb / 20 = " +
                      fmt::format("{:.6g}", step_at(500, 0)) + " at this G") &&
                 Contains("closest approach d = 0 ") && Contains("contacts cannot keep grains apart") &&
                 Contains(fmt::format("keep gravity.G at or below {:.6g}", std::pow(step_at(1, 0) / 0.04, 2))));
  // Once per run: a G raised further, and one set again after a restored state (which carries it), say nothing new.
  set_G(*sim, 1000.0);
  CHECK(warnings_starting(*sim, "gravity.G") == 1);
  auto restored = Simulation::create(Scene::from_string(two_grains_with_contacts(0.05), "pair"));
  restored->restore_state(sim->save_state());
  set_G(*restored, 2000.0);
  restored->get("kinetic_energy");
  CHECK(restored->warnings().empty());
  // A scene whose start-up G already exceeds the rule warns at the start-up, and not again when a host raises G.
  auto coarse = Simulation::create(Scene::from_string(two_grains_with_contacts(500), "coarse"));
  REQUIRE(coarse->warnings().size() == 1);
  CHECK_THAT(coarse->warnings()[0], Contains("exceeds T_orb / 20") && Contains("closest approach d = 0 "));
  set_G(*coarse, 1000.0);
  CHECK(coarse->warnings().size() == 1);
}

TEST_CASE("a host's G moves k* with it, and t_ff keeps the initial cloud's G", "[gravity]") {
  // k* kept at the initial G's value after a host changes G would have the energy check's "contacts too soft
  // (k* = ...)" quote a k* a thousand times too stiff after G is raised a thousandfold.
  auto sim = Simulation::create(
      Scene::from_file(std::string(GRAINS_MODELS_DIR) + "/aggregation.toml", {"run.threads=1", "particles.count=50"}));
  const double G = sim->get(sim->index_of("gravity.G")), k_star = sim->get("normalised_stiffness");
  const double t_ff = sim->get("free_fall_time");
  set_G(*sim, 1000 * G);
  sim->step_n(1);
  CHECK(sim->get("normalised_stiffness") == Approx(k_star / 1000).epsilon(1e-12));
  CHECK(sim->get("free_fall_time") == t_ff);
  set_G(*sim, 0.0);   // gravity off: no k*, rather than inf in the outputs
  sim->step_n(1);
  CHECK(std::isnan(sim->get("normalised_stiffness")));
}
