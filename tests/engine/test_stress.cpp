// Stress tensor: the contact virial of compressed lattices against their closed forms, and the
// kinetic part against the ideal gas.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "analysis/stress.hpp"
#include "core/simulation.hpp"
#include "core/system.hpp"
#include "interactions/contact_forces.hpp"
#include "io/scene.hpp"

using namespace grains;

namespace {

// Equal disks of diameter `diameter` at the given centres in a periodic box, their contact virial
// evaluated by the pair loop with `threads` threads (linear law of stiffness k, no damping).
template <int D>
Tensor<D> lattice_virial(const std::vector<Vec<D>>& centres, const Vec<D>& lengths, double diameter, double k,
                         int threads) {
  System<D> s;
  s.particles.resize(centres.size());
  for (std::size_t i = 0; i < centres.size(); ++i) {
    s.particles.position[i] = centres[i];
    s.particles.set_mass_and_radius(i, 1.0, 0.5 * diameter);
  }
  s.box.length = lengths;
  s.box.periodic.fill(true);
  s.threads = threads;
  s.thread_force.assign(threads, std::vector<Vec<D>>(centres.size(), Vec<D>::Zero()));
  s.thread_torque.assign(threads, std::vector<Spin<D>>(centres.size(), Spin<D>::Zero()));
  s.neighbours.configure(0.0, 0.1 * diameter);
  s.neighbours.build(s.particles.position, s.particles.radius, s.box, threads);
  ContactForces<D, LinearContactLaw<false>, CoulombFriction> contacts(LinearContactLaw<false>{k, 0.0, 1.0},
                                                                      CoulombFriction{0.5, 1.0, 0.0, false});
  s.want_virial = true;
  contacts.add_forces(s);
  return s.virial;
}

// A triangular lattice of nx by ny disks at spacing s (ny even: the rows close periodically), rows along x:
// the centres and the periodic box.
std::pair<std::vector<Vec<2>>, Vec<2>> triangular_lattice(int nx, int ny, double s) {
  const double h = std::sqrt(3.0) / 2 * s;
  std::vector<Vec<2>> x;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) x.emplace_back((i + 0.5 * (j % 2) + 0.25) * s, (j + 0.5) * h);
  return {x, Vec<2>(nx * s, ny * h)};
}

}  // namespace

TEST_CASE("contact stress of a compressed square lattice is k delta / s on both axes", "[stress]") {
  const int n = 6;
  const double s = 0.98, diameter = 1.0, k = 1e4, delta = diameter - s;
  std::vector<Vec<2>> x;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) x.emplace_back((i + 0.5) * s, (j + 0.5) * s);
  const Vec<2> L(n * s, n * s);
  for (int threads : {1, 2}) {
    const Tensor<2> sigma = contact_stress<2>(lattice_virial<2>(x, L, diameter, k, threads), L.prod());
    CHECK(sigma(0, 0) == Approx(k * delta / s).epsilon(1e-12));
    CHECK(sigma(1, 1) == Approx(k * delta / s).epsilon(1e-12));
    CHECK(std::abs(sigma(0, 1)) < 1e-9 * sigma(0, 0));
    CHECK(std::abs(sigma(1, 0)) < 1e-9 * sigma(0, 0));
  }
}

TEST_CASE("contact stress of a compressed triangular lattice is sqrt(3) k delta / s, isotropic", "[stress]") {
  const double s = 0.97, diameter = 1.0, k = 2e3, delta = diameter - s;
  const auto [x, L] = triangular_lattice(6, 6, s);
  const double expected = std::sqrt(3.0) * k * delta / s;
  for (int threads : {1, 2}) {
    const Tensor<2> sigma = contact_stress<2>(lattice_virial<2>(x, L, diameter, k, threads), L.prod());
    CHECK(sigma(0, 0) == Approx(expected).epsilon(1e-12));
    CHECK(sigma(1, 1) == Approx(expected).epsilon(1e-12));
    CHECK(std::abs(sigma(0, 1)) < 1e-9 * expected);
    CHECK(pressure<2>(sigma) == Approx(expected).epsilon(1e-12));
  }
}

TEST_CASE("contact stress of a compressed simple cubic lattice is k delta / s^2 on each axis", "[stress]") {
  const int n = 5;
  const double s = 0.99, diameter = 1.0, k = 1e4, delta = diameter - s;
  std::vector<Vec<3>> x;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int l = 0; l < n; ++l) x.emplace_back((i + 0.5) * s, (j + 0.5) * s, (l + 0.5) * s);
  const Vec<3> L = Vec<3>::Constant(n * s);
  for (int threads : {1, 2}) {
    const Tensor<3> sigma = contact_stress<3>(lattice_virial<3>(x, L, diameter, k, threads), L.prod());
    for (int a = 0; a < 3; ++a) CHECK(sigma(a, a) == Approx(k * delta / (s * s)).epsilon(1e-12));
    CHECK(sigma.cwiseAbs().maxCoeff() == Approx(sigma(0, 0)).epsilon(1e-12));   // no shear stress
  }
}

TEST_CASE("a stretched lattice with no contacts carries no contact stress", "[stress]") {
  std::vector<Vec<2>> x;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) x.emplace_back(i * 1.2, j * 1.2);
  CHECK(lattice_virial<2>(x, Vec<2>(6.0, 6.0), 1.0, 1e4, 1).isZero(0));
}

TEST_CASE("kinetic stress of an ideal gas is n k T on the diagonal", "[stress]") {
  // Velocities +-v on each axis in turn: every particle carries m v^2 on one axis only.
  Particles<3> P;
  const int N = 300;
  P.resize(N);
  const double m = 2.0, v = 0.7, V = 50.0;
  for (int i = 0; i < N; ++i) {
    P.set_mass_and_radius(i, m, 0.5);
    P.velocity[i][i % 3] = (i % 2 ? v : -v);
  }
  const Tensor<3> sigma = kinetic_stress<3>(P, V);
  // Ideal gas: P = N k T / V with k T = m <v_x^2> = m v^2 / 3 averaged over the axes.
  const double kT = m * v * v / 3;
  for (int a = 0; a < 3; ++a) CHECK(sigma(a, a) == Approx(N * kT / V).epsilon(1e-12));
  CHECK(pressure<3>(sigma) == Approx(N * kT / V).epsilon(1e-12));
  CHECK(std::abs(sigma(0, 1)) == 0.0);
}

TEST_CASE("the Simulation's stress: a compressed lattice's contact part in closed form, a gas's kinetic part summed",
          "[stress]") {
  // What the runner, the FMUs and the barostat read (stress_ab, pressure, pressure_kinetic), against sums made
  // here from the scene's own numbers. Leaving out the kinetic part passed every other test (a review's
  // seeded bug), since the barostat tests compare the pressure with itself.
  const auto scene = [](const std::vector<Vec<2>>& x, const std::vector<Vec<2>>& v, const std::vector<double>& m,
                        const Vec<2>& L, int threads) {
    std::vector<std::string> xs, vs, ms;
    for (std::size_t i = 0; i < x.size(); ++i) {
      xs.push_back(fmt::format("[{:.17g}, {:.17g}]", x[i][0], x[i][1]));
      vs.push_back(fmt::format("[{:.17g}, {:.17g}]", v[i][0], v[i][1]));
      ms.push_back(fmt::format("{:.17g}", m[i]));
    }
    return Simulation::create(Scene::from_string(fmt::format(R"(
[scene]
dimension = 2
[particles]
layout = "list"
positions = [{}]
velocity = "list"
velocities = [{}]
masses = [{}]
diameter = 1.0
[box]
periodic = true
lengths = [{:.17g}, {:.17g}]
[adhesion]
enabled = true
[cell]
enabled = true
[run]
threads = {}
)", fmt::join(xs, ", "), fmt::join(vs, ", "), fmt::join(ms, ", "), L[0], L[1], threads), "stress"));
  };
  SECTION("a triangular lattice at rest, each contact pressed to F = K_N 3 delta0 - F0 = 2 F0: sqrt(3) F / l") {
    const double kn = 1e5, l = 1 - 3 / kn;   // F0 = 1, delta0 = F0 / K_N
    const auto [x, L] = triangular_lattice(6, 6, l);
    auto s = scene(x, std::vector<Vec<2>>(x.size(), Vec<2>::Zero()), std::vector<double>(x.size(), 1.0), L, 1);
    const double sigma = std::sqrt(3.0) * 2 / l;
    CHECK(s->get("stress_xx") == Approx(sigma).epsilon(1e-9));
    CHECK(s->get("stress_yy") == Approx(sigma).epsilon(1e-9));
    CHECK(std::abs(s->get("stress_xy")) < 1e-9 * sigma);
    CHECK(s->get("pressure") == Approx(sigma).epsilon(1e-9));
    CHECK(s->get("pressure_kinetic") == 0);
  }
  SECTION("a dilute gas of unequal masses, no contact: sum m v v / V, on one and two threads") {
    std::vector<Vec<2>> x, v;
    std::vector<double> m;
    std::mt19937_64 rng(11);
    std::normal_distribution<double> g(0.0, 0.3);
    std::uniform_real_distribution<double> u(0.5, 4.0);
    for (int j = 0; j < 8; ++j)
      for (int i = 0; i < 8; ++i) x.emplace_back(3.0 * i + 1.5, 3.0 * j + 1.5), v.emplace_back(g(rng), g(rng)), m.push_back(u(rng));
    const Vec<2> L(24.0, 24.0);
    Tensor<2> sum = Tensor<2>::Zero();
    for (std::size_t i = 0; i < x.size(); ++i) sum += m[i] * v[i] * v[i].transpose();
    const Tensor<2> expected = sum / L.prod();
    for (const int threads : {1, 2}) {
      auto s = scene(x, v, m, L, threads);
      REQUIRE(s->get("contacts") == 0);
      CHECK(s->get("stress_xx") == Approx(expected(0, 0)).epsilon(1e-12));
      CHECK(s->get("stress_yy") == Approx(expected(1, 1)).epsilon(1e-12));
      CHECK(s->get("stress_xy") == Approx(expected(0, 1)).epsilon(1e-12));
      CHECK(s->get("pressure_kinetic") == Approx(expected.trace() / 2).epsilon(1e-12));
      CHECK(s->get("pressure") == Approx(expected.trace() / 2).epsilon(1e-12));
    }
  }
}
