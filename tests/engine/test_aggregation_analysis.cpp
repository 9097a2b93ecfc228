// Aggregation analysis (physics.md section 8): cluster graph, fractal dimension, and the gravity-scene
// observables (cluster counts, aggregation time, free-fall time) end to end.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <utility>

#include <fmt/format.h>

#include "analysis/clusters.hpp"
#include "analysis/fractal_dimension.hpp"
#include "cloud_scene.hpp"
#include "core/simulation.hpp"
#include "io/scene.hpp"
#include "plain_lattice_scene.hpp"

using namespace grains;

namespace {

// Brute-force O(N^2) cluster count, the reference for the cell-grid search.
std::size_t brute_force_count(const std::vector<Vec<3>>& x, const std::vector<double>& r, double tol) {
  const std::size_t N = x.size();
  std::vector<int> parent(N);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int i) {
    while (parent[i] != i) i = parent[i];
    return i;
  };
  for (std::size_t i = 0; i < N; ++i)
    for (std::size_t j = i + 1; j < N; ++j)
      if ((x[i] - x[j]).norm() < r[i] + r[j] + tol) parent[find(int(i))] = find(int(j));
  std::size_t n = 0;
  for (std::size_t i = 0; i < N; ++i) n += find(int(i)) == int(i);
  return n;
}

}  // namespace

TEST_CASE("clusters: two separated touching chains and an isolated particle", "[aggregation]") {
  std::vector<Vec<3>> x;
  std::vector<double> r, m;
  for (int k = 0; k < 5; ++k) x.emplace_back(k * 1.0, 0, 0), r.push_back(0.5), m.push_back(1);      // chain A, mass 5
  for (int k = 0; k < 3; ++k) x.emplace_back(k * 1.0, 10, 0), r.push_back(0.5), m.push_back(3);     // chain B, mass 9
  x.emplace_back(0, 0, 20), r.push_back(0.5), m.push_back(1);                                       // isolated
  const auto cs = find_clusters<3>(x, r, m, 1e-3);
  CHECK(cs.count == 3);
  for (int k = 1; k < 5; ++k) CHECK(cs.label[k] == cs.label[0]);
  for (int k = 6; k < 8; ++k) CHECK(cs.label[k] == cs.label[5]);
  CHECK(cs.label[0] != cs.label[5]);
  CHECK(cs.label[8] != cs.label[0]);
  CHECK(cs.label[8] != cs.label[5]);
  CHECK(cs.largest == cs.label[5]);
  CHECK(cs.largest_fraction == Approx(9.0 / 15.0).epsilon(1e-14));

  // Equal masses: chain A is the largest.
  std::fill(m.begin(), m.end(), 1.0);
  const auto eq = find_clusters<3>(x, r, m, 1e-3);
  CHECK(eq.largest == eq.label[0]);
  CHECK(eq.largest_fraction == Approx(5.0 / 9.0).epsilon(1e-14));

  // 2D as well.
  std::vector<Vec<2>> x2;
  for (const auto& p : x) x2.push_back(p.head<2>());
  x2.back() = Vec<2>(0, 20);
  CHECK(find_clusters<2>(x2, r, m, 1e-3).count == 3);
}

TEST_CASE("clusters: the tolerance is honoured (gap just below / above tol)", "[aggregation]") {
  const double tol = 0.01, R = 0.5;
  const std::vector<double> r{R, 0.25}, m{1, 1};
  for (double gap : {0.0, 0.99 * tol, 1.01 * tol, 2 * tol}) {
    const std::vector<Vec<3>> x{Vec<3>(0, 0, 0), Vec<3>(R + 0.25 + gap, 0, 0)};
    const auto cs = find_clusters<3>(x, r, m, tol);
    INFO("gap " << gap);
    CHECK(cs.count == (gap < tol ? 1u : 2u));
    CHECK(cs.largest_fraction == Approx(gap < tol ? 1.0 : 0.5));
  }
  // Zero tolerance: touching exactly is not linked (strict d < R_i + R_j), overlapping is.
  const std::vector<Vec<3>> touching{Vec<3>(0, 0, 0), Vec<3>(0.75, 0, 0)}, overlapping{Vec<3>(0, 0, 0), Vec<3>(0.7499, 0, 0)};
  CHECK(find_clusters<3>(touching, r, m, 0.0).count == 2);
  CHECK(find_clusters<3>(overlapping, r, m, 0.0).count == 1);
}

TEST_CASE("clusters: the cell-grid search agrees with brute force on a random polydisperse cloud", "[aggregation]") {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> u(-6, 6), ur(0.2, 0.6);
  std::vector<Vec<3>> x;
  std::vector<double> r, m;
  for (int i = 0; i < 1500; ++i) x.emplace_back(u(rng), u(rng), u(rng)), r.push_back(ur(rng)), m.push_back(1);
  // The cloud alone has its cells in a plain array; a far escaper makes the grid a hash map. Both must give
  // brute force's count and the same labels (the escaper alone in the last cluster).
  std::vector<ClusterStats> dense;
  for (double tol : {0.0, 0.05, 0.3}) dense.push_back(find_clusters<3>(x, r, m, tol));
  x.emplace_back(1e6, -1e6, 3e5), r.push_back(0.5), m.push_back(1);
  int k = 0;
  for (double tol : {0.0, 0.05, 0.3}) {
    const auto cs = find_clusters<3>(x, r, m, tol);
    INFO("tol " << tol);
    CHECK(cs.count == brute_force_count(x, r, tol));
    CHECK(cs.count > 1);
    const auto& d = dense[k++];
    CHECK(d.count + 1 == cs.count);
    CHECK(std::equal(d.label.begin(), d.label.end(), cs.label.begin()));
    CHECK(cs.label.back() == int(d.count));
  }
  // Grains at the ends of the double range: two far apart, one touching the second.
  const std::vector<Vec<3>> far{Vec<3>(-1e300, 0, 0), Vec<3>(1e300, 0, 0), Vec<3>(1e300, 0, 0)};
  CHECK(find_clusters<3>(far, {0.5, 0.5, 0.5}, {1, 1, 1}, 0.0).count == 2);
}

TEST_CASE("fractal dimension: compact lattice ball ~3, straight chain ~1, tiny sets NaN", "[aggregation]") {
  // Simple cubic lattice (spacing = diameter = 1) inside a ball: ~4000 particles.
  std::vector<Vec<3>> ball;
  const int n = 10;
  const double Rb = 9.85;
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j)
      for (int k = -n; k <= n; ++k)
        if (i * i + j * j + k * k <= Rb * Rb) ball.emplace_back(i, j, k);
  const std::vector<double> rb(ball.size(), 0.5), mb(ball.size(), 1.0);
  const double df_ball = fractal_dimension<3>(ball, rb, mb);

  std::vector<Vec<3>> chain;
  for (int i = 0; i < 400; ++i) chain.emplace_back(i * 1.0, 0, 0);
  const std::vector<double> rc(chain.size(), 0.5), mc(chain.size(), 1.0);
  const double df_chain = fractal_dimension<3>(chain, rc, mc);

  WARN(fmt::format("D_f: lattice ball of {} particles {:.4f}; chain of {} touching spheres {:.4f}", ball.size(), df_ball,
                   chain.size(), df_chain));
  CHECK(ball.size() > 3800);
  CHECK(ball.size() < 4200);
  CHECK(std::abs(df_ball - 3) < 0.1);
  CHECK(std::abs(df_chain - 1) < 0.1);

  // Five touching spheres: the 90 % radius is below two diameters, no scaling range.
  std::vector<Vec<3>> few(chain.begin(), chain.begin() + 5);
  CHECK(std::isnan(fractal_dimension<3>(few, std::vector<double>(5, 0.5), std::vector<double>(5, 1.0))));
  CHECK(std::isnan(fractal_dimension<3>(std::vector<Vec<3>>{Vec<3>::Zero()}, {0.5}, {1.0})));
}

namespace {

// Largest distance of a particle from the centre of mass.
double largest_distance_from_centre(const ParticleView& p) {
  double centre[3] = {0, 0, 0}, mass = 0, largest = 0;
  for (std::size_t i = 0; i < p.count; ++i) {
    for (int a = 0; a < 3; ++a) centre[a] += p.mass[i] * p.position[3 * i + a];
    mass += p.mass[i];
  }
  for (std::size_t i = 0; i < p.count; ++i) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += std::pow(p.position[3 * i + a] - centre[a] / mass, 2);
    largest = std::max(largest, std::sqrt(d2));
  }
  return largest;
}

// Kinetic energy (translation and spin of solid spheres, I = 2/5 m R^2) and the softened gravitational
// potential -sum_{i<j} G m_i m_j / sqrt(d^2 + eps^2), summed directly.
std::pair<double, double> energies(const ParticleView& p, double G, double eps) {
  double kinetic = 0, potential = 0;
  for (std::size_t i = 0; i < p.count; ++i)
    for (int a = 0; a < 3; ++a)
      kinetic += 0.5 * p.mass[i] * (std::pow(p.velocity[3 * i + a], 2) +
                                    0.4 * p.radius[i] * p.radius[i] * std::pow(p.angular_velocity[3 * i + a], 2));
  for (std::size_t i = 0; i < p.count; ++i)
    for (std::size_t j = i + 1; j < p.count; ++j) {
      double d2 = eps * eps;
      for (int a = 0; a < 3; ++a) d2 += std::pow(p.position[3 * j + a] - p.position[3 * i + a], 2);
      potential -= G * p.mass[i] * p.mass[j] / std::sqrt(d2);
    }
  return {kinetic, potential};
}

}  // namespace

TEST_CASE("aggregation observables: a cold self-gravitating cloud aggregates, save/restore keeps aggregation_time",
          "[aggregation]") {
  const std::string text =
      cloud_scene({.count = 200, .seed = 3, .restitution = 0.1, .duration = 0.01, .threads = 2},
                  "[analysis]\naggregation_threshold = 0.9\nevery = 50\n");
  auto sim = Simulation::create(Scene::from_string(text, "cloud"));
  const double tff = sim->get("free_fall_time");
  // t_ff = sqrt(R0^3 / (G M)), R0 the largest distance from the initial centre of mass (physics.md section 8)
  CHECK(tff == Approx(std::sqrt(std::pow(largest_distance_from_centre(sim->particles()), 3) / (1.0 * 200))).epsilon(1e-13));
  CHECK(sim->get("cluster_count") > 150);
  CHECK(sim->get("cluster_index") == Approx(sim->get("cluster_count") / 200));
  CHECK(std::isnan(sim->get("aggregation_time")));
  CHECK(sim->get("virial_ratio") == 0.0);
  CHECK(sim->get("time_over_free_fall") == 0.0);
  // k* = k_n / k_g: k_n = m* (pi^2 + ln^2 e) / t_c^2 with m* = 1/2, e = 0.1, t_c = 0.01; k_g = G m^2 / (4 R^3) = 2.
  const double ln_e = std::log(0.1), pi = std::acos(-1.0);
  CHECK(sim->get("normalised_stiffness") == Approx(0.5 * (pi * pi + ln_e * ln_e) / 1e-4 / 2.0).epsilon(1e-12));
  const double f0 = sim->get("largest_cluster_fraction");

  const auto start = std::chrono::steady_clock::now();
  std::vector<std::byte> saved;
  double t_saved = 0;
  // Run in chunks without reading in between (the aggregation time must be tracked inside stepping);
  // keep the state at 0.5 t_ff, before aggregation.
  auto run_to = [&](double t_end) {
    while (sim->time() < t_end - 1e-9 * tff) {
      sim->step(0.25 * tff);
      if (saved.empty() && sim->time() >= 0.5 * tff) saved = sim->save_state(), t_saved = sim->time();
    }
  };
  run_to(2.5 * tff);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double f_end = sim->get("largest_cluster_fraction"), t_agg = sim->get("aggregation_time");
  WARN(fmt::format("cold cloud of 200: t_ff = {:.4g}; f_max {:.3f} -> {:.3f} (2.5 t_ff); N_c {}; t_agg / t_ff = {:.3f}; "
                   "Q = {:.3g}; D_f = {:.3f}; {} steps in {:.1f} s",
                   tff, f0, f_end, sim->get("cluster_count"), t_agg / tff, sim->get("virial_ratio"),
                   sim->get("fractal_dimension"), sim->step_count(), seconds));
  CHECK(f_end > f0);
  CHECK(f_end >= 0.9);
  REQUIRE(std::isfinite(t_agg));
  CHECK(t_agg > t_saved);
  CHECK(t_agg <= sim->time());
  CHECK(sim->get("time_over_free_fall") == Approx(sim->time() / tff));
  // Q = K / |W| from the particles themselves: translation and spin, softened pair potential (epsilon = 0.1 R_min)
  const auto [kinetic, potential] = energies(sim->particles(), 1.0, 0.1 * 0.5);
  CHECK(sim->get("virial_ratio") == Approx(kinetic / std::abs(potential)).epsilon(1e-10));

  // Restoring the pre-aggregation state brings back its undefined aggregation time; running on
  // reproduces the same aggregation time; restoring the end state brings it back.
  const auto end_state = sim->save_state();
  sim->restore_state(saved);
  CHECK(sim->time() == t_saved);
  CHECK(std::isnan(sim->get("aggregation_time")));
  sim->restore_state(end_state);
  CHECK(sim->get("aggregation_time") == t_agg);
  sim->restore_state(saved);
  run_to(2.5 * tff);
  CHECK(sim->get("aggregation_time") == t_agg);
}

TEST_CASE("aggregation observables: absent without gravity, scene keys are validated", "[aggregation]") {
  const std::string plain = plain_lattice_scene();
  auto sim = Simulation::create(Scene::from_string(plain, "plain"));
  CHECK_THROWS(sim->index_of("cluster_count"));
  CHECK_THROWS(sim->index_of("aggregation_time"));
  // The aggregation analysis's keys belong to gravity scenes: refused without gravity, naming what they need.
  const std::string keys = "[analysis]\naggregation_threshold = 1.0\nevery = 1\ncluster_tolerance = 0.0\n";
  CHECK_THROWS_WITH(Scene::from_string(plain + keys, "plain").validate(), Catch::Contains("needs gravity.enabled = true"));
  // With gravity their values are checked against their ranges.
  const std::string cloud = cloud_scene({.count = 20, .seed = 1, .restitution = 0.5, .duration = 0.1, .threads = 1});
  CHECK_NOTHROW(Scene::from_string(cloud + keys, "good").validate());
  for (std::string bad : {"aggregation_threshold = 0.0", "aggregation_threshold = 1.5", "every = 0", "cluster_tolerance = -1.0"})
    CHECK_THROWS_WITH(Scene::from_string(cloud + "[analysis]\n" + bad + "\n", "bad").validate(),
                      Catch::Contains("analysis." + bad.substr(0, bad.find(' '))));
}

TEST_CASE("clusters: sizes over many classes agree with brute force, and one large grain is no quadratic search",
          "[aggregation]") {
  // Brute force's labels, in order of first appearance as find_clusters numbers them.
  auto brute_labels = [](const std::vector<Vec<3>>& x, const std::vector<double>& r, double tol) {
    std::vector<int> parent(x.size()), label(x.size(), -1), of_root(x.size(), -1);
    std::iota(parent.begin(), parent.end(), 0);
    auto find = [&](int i) {
      while (parent[i] != i) i = parent[i];
      return i;
    };
    for (std::size_t i = 0; i < x.size(); ++i)
      for (std::size_t j = i + 1; j < x.size(); ++j)
        if ((x[i] - x[j]).norm() < r[i] + r[j] + tol) parent[find(int(i))] = find(int(j));
    int next = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
      int& l = of_root[find(int(i))];
      if (l < 0) l = next++;
      label[i] = l;
    }
    return label;
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Vec<3>> x;
  std::vector<double> r, m;
  for (int i = 0; i < 2000; ++i)   // radii over 2.2 decades, mostly small
    x.emplace_back(40 * u(rng), 40 * u(rng), 40 * u(rng)), r.push_back(0.05 * std::pow(10.0, 2.2 * u(rng) * u(rng))),
        m.push_back(r.back());
  for (double tol : {0.0, 0.05}) {
    const auto cs = find_clusters<3>(x, r, m, tol);
    INFO("tol " << tol);
    CHECK(cs.count > 10);
    CHECK(cs.label == brute_labels(x, r, tol));
  }

  // 49,000 unit spheres on a cubic lattice 1.5 apart and one of 40 diameters at its centre: one grid of cells
  // 2 R_max + tol wide held the cloud in 8 cells, 1.2e9 pairs (about 7 s here, now 0.05 s).
  std::vector<Vec<3>> cloud{Vec<3>(0, 0, 0)};
  std::vector<double> rc{20.0}, mc{8000.0};
  for (int i = -19; i <= 19; ++i)
    for (int j = -19; j <= 19; ++j)
      for (int k = -19; k <= 19; ++k)
        if (const Vec<3> p(1.5 * i, 1.5 * j, 1.5 * k); p.norm() > 20.25) cloud.push_back(p), rc.push_back(0.5), mc.push_back(1);
  const auto cs = find_clusters<3>(cloud, rc, mc, 1e-3);
  std::size_t linked = 0;   // the lattice's spheres do not touch one another: the clusters are the large one's
  for (std::size_t i = 1; i < cloud.size(); ++i) linked += cloud[i].norm() < 20.5 + 1e-3;
  CHECK(cloud.size() > 45000);
  CHECK(linked > 200);
  CHECK(cs.count == cloud.size() - linked);
  // The cost as pairs measured, not time (a timed test fails on a slow machine).
  INFO("pairs tested: " << cs.pairs_tested);
  CHECK(cs.pairs_tested < 30 * cloud.size());
}

TEST_CASE("clusters: many large grains among many far smaller ones are no quadratic search", "[aggregation]") {
  // 40,000 disks of radius 1 and 40,000 of 0.001 spread thin over a square 500 wide. A large grain searching the tiny
  // ones' grid within its own reach scanned a million cells or, fewer, every tiny grain: 1.6e9 pairs (about
  // 1.9 s here); each grain looking up the larger class's grid instead, 0.17 s.
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 500);
  std::vector<Vec<2>> x;
  std::vector<double> r, m;
  for (int i = 0; i < 80000; ++i) x.emplace_back(u(rng), u(rng)), r.push_back(i % 2 ? 1e-3 : 1.0), m.push_back(r.back());
  const auto cs = find_clusters<2>(x, r, m, 0.0);
  CHECK(cs.count + 1000 < x.size());   // many grains linked (large ones touching, tiny ones on large ones)
  INFO("pairs tested: " << cs.pairs_tested);
  CHECK(cs.pairs_tested < 20 * x.size());
}
