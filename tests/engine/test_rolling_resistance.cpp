// Rolling resistance (physics.md section 5) against closed forms, and the conservation laws and
// bit-identical restart of the whole consolidation contact law (adhesion + friction + rolling).
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "adhesive_scene.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "polydisperse_particles.hpp"

using namespace grains;

namespace {
constexpr double F0 = 1.0, KN = 1e5;
constexpr double KR = 1e-4 * KN;   // K_R = 1e-4 K_N a^2, a = 1

// Two unit-mass grains of diameter 1 bonded at rest at the equilibrium overlap F0 / K_N, grain 1
// spinning at w0 about z (a rolling rotation: perpendicular to the normal x).
std::string spinning_pair(int dim, double w0, double mu_r, std::vector<double> axis = {0, 0, 1}) {
  auto at = [dim](double x) {
    std::vector<double> r(dim, 0.0);
    r[0] = x;
    return r;
  };
  ListedParticles p;
  p.positions = {at(0), at(1 - F0 / KN)};
  p.velocities = {at(0), at(0)};
  p.diameters = {1, 1};
  p.masses = {1, 1};
  const std::string spins = dim == 2 ? fmt::format("angular_velocities = [[0], [{}]]", w0)
                                     : fmt::format("angular_velocities = [[0, 0, 0], [{}, {}, {}]]", w0 * axis[0],
                                                   w0 * axis[1], w0 * axis[2]);
  return adhesive_scene(dim, p, fmt::format("[rolling]\ncoefficient = {}\n", mu_r), spins);
}

// Spin of grain 1 minus grain 0 about `axis` (2D: the scalar spin).
double relative_spin(const Simulation& s, std::vector<double> axis = {0, 0, 1}) {
  const auto v = s.particles();
  if (v.dimension == 2) return v.angular_velocity[1] - v.angular_velocity[0];
  double w = 0;
  for (int a = 0; a < 3; ++a) w += (v.angular_velocity[3 + a] - v.angular_velocity[a]) * axis[a];
  return w;
}
double total_spin(const Simulation& s) {
  const auto v = s.particles();
  return v.dimension == 2 ? v.angular_velocity[0] + v.angular_velocity[1] : v.angular_velocity[2] + v.angular_velocity[5];
}
}  // namespace

// Elastic regime: the relative rotation is a harmonic oscillator, Omega^2 = K_R (1/I_i + 1/I_j).
TEST_CASE("rolling resistance, elastic regime: the relative spin oscillates at sqrt(K_R (1/I_i + 1/I_j))", "[rolling]") {
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    const double inertia = (dim == 2 ? 0.5 : 0.4) * 1.0 * 0.25;
    const double omega = std::sqrt(KR * 2 / inertia), w0 = 0.01;
    REQUIRE(KR * w0 / omega < 0.05 * F0);   // the moment stays well inside the bound mu_R F0 below
    auto s = Simulation::create(Scene::from_string(spinning_pair(dim, w0, 0.05), "rolling"));
    const double energy = s->get("kinetic_energy") + s->get("elastic_energy");
    double worst = 0;
    for (int k = 1; k <= 40; ++k) {
      s->step(0.05 * 2 * std::numbers::pi / omega);   // 2 periods in 40 samples
      worst = std::max(worst, std::abs(relative_spin(*s) - w0 * std::cos(omega * s->time())));
    }
    CHECK(worst < 1e-4 * w0);
    CHECK(total_spin(*s) == Approx(w0).epsilon(1e-12));   // a pure couple: the spins exchange, their sum stays
    // Spin energy and the rolling spring's energy (in elastic_energy) exchange without loss.
    CHECK(s->get("kinetic_energy") + s->get("elastic_energy") == Approx(energy).epsilon(1e-6));
  }
}

// Bounded regime: beyond the bound the moment is mu_R F_N^e = mu_R F0 and the relative spin falls linearly.
TEST_CASE("rolling resistance, rolling regime: the moment is capped at mu_R K_N delta", "[rolling]") {
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    const double inertia = (dim == 2 ? 0.5 : 0.4) * 1.0 * 0.25, mu_r = 0.005, w0 = 1.0;
    auto s = Simulation::create(Scene::from_string(spinning_pair(dim, w0, mu_r), "rolling"));
    s->step(0.2);
    const double t1 = s->time(), w1 = relative_spin(*s);
    s->step(0.8);
    const double slope = (relative_spin(*s) - w1) / (s->time() - t1);
    CHECK(slope == Approx(-mu_r * F0 * 2 / inertia).epsilon(1e-9));
    CHECK(total_spin(*s) == Approx(w0).epsilon(1e-12));
  }
}

// A rolling spring so stiff that its moment squared overflows a double (3D; 2D takes no square): the cap divided by
// sqrt(inf) and zero the moment, rolling resistance off unsaid.
TEST_CASE("rolling resistance: a spring whose moment squared overflows still rolls at the bound", "[rolling]") {
  const double inertia = 0.4 * 1.0 * 0.25, mu_r = 0.005, w0 = 1.0;
  std::string scene = spinning_pair(3, w0, mu_r);
  const auto at = scene.find("[rolling]\n");
  REQUIRE(at != std::string::npos);
  scene.insert(at + 10, "stiffness_ratio = 1e160\n");
  auto s = Simulation::create(Scene::from_string(scene, "rolling"));
  s->step(0.2);
  const double t1 = s->time(), w1 = relative_spin(*s);
  s->step(0.8);
  CHECK((relative_spin(*s) - w1) / (s->time() - t1) == Approx(-mu_r * F0 * 2 / inertia).epsilon(1e-9));
}

TEST_CASE("rolling resistance ignores twisting about the normal (3D)", "[rolling]") {
  auto s = Simulation::create(Scene::from_string(spinning_pair(3, 1.0, 0.005, {1, 0, 0}), "twist"));
  s->step(0.5);
  CHECK(relative_spin(*s, {1, 0, 0}) == 1.0);
}

namespace {
// A dense cluster of cohesive grains in open space with friction and rolling resistance.
std::string cohesive_cluster(int dim, int threads) {
  return polydisperse_particles(dim, 64, dim == 2 ? 0.5 : 0.35, 3, "velocity = \"gaussian\"\nkinetic_energy = 0.5\n") +
         fmt::format(R"(
[box]
periodic = false
[adhesion]
enabled = true
[friction]
coefficient = 0.5
[rolling]
coefficient = 0.005
[run]
threads = {}
)", threads);
}
}  // namespace

TEST_CASE("adhesion + friction + rolling conserve momentum and angular momentum", "[rolling][adhesion]") {
  for (int dim : {2, 3}) {
    INFO("dimension " << dim);
    auto s = Simulation::create(Scene::from_string(cohesive_cluster(dim, 1), "cluster"));
    auto read = [&](const std::string& name) { return s->get(name); };
    const std::vector<std::string> names =
        dim == 2 ? std::vector<std::string>{"momentum_x", "momentum_y", "angular_momentum_z"}
                 : std::vector<std::string>{"momentum_x", "momentum_y", "momentum_z", "angular_momentum_x",
                                            "angular_momentum_y", "angular_momentum_z"};
    std::vector<double> start;
    for (const auto& n : names) start.push_back(read(n));
    // Scale of the sums: total |m v|. Measured changes (2D, 3D): momentum 2.7e-16 and 1.5e-16 of it at most,
    // angular momentum 9.0e-14 and 1.4e-14 (round-off): bounds 1e-14 and 1e-12.
    double scale = 0;
    const auto v = s->particles();
    for (std::size_t i = 0; i < v.count; ++i)
      for (int a = 0; a < dim; ++a) scale += v.mass[i] * std::abs(v.velocity[i * dim + a]);
    long contacts = 0;
    for (int k = 0; k < 20; ++k) s->step_n(100), contacts = std::max(contacts, long(read("contacts")));
    CHECK(contacts > 5);   // not a vacuous test: grains collide and bond
    for (std::size_t n = 0; n < names.size(); ++n) {
      INFO(names[n]);
      WARN(fmt::format("{}D {}: change {:.3g} of sum |m v| = {:.6g}", dim, names[n], (read(names[n]) - start[n]) / scale, scale));
      CHECK(std::abs(read(names[n]) - start[n]) < (n < std::size_t(dim) ? 1e-14 : 1e-12) * scale);
    }
  }
}

TEST_CASE("save_state / restore_state continues bit-identically with rolling history", "[rolling][seam]") {
  for (int dim : {2, 3}) {
    auto s = Simulation::create(Scene::from_string(cohesive_cluster(dim, 2), "cluster"));
    s->step_n(500);
    REQUIRE(s->get("contacts") > 0);
    const auto saved = s->save_state();
    s->step_n(200);
    const auto reference = s->particles();
    s->restore_state(saved);
    s->step_n(200);
    CHECK(s->particles().position == reference.position);
    CHECK(s->particles().angular_velocity == reference.angular_velocity);
    CHECK(s->particles().velocity == reference.velocity);
  }
}
