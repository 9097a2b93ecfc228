// Benchmark, hidden from the suite (run: grains_tests "[.threads-bench]"): what two cores pay to exchange a
// step's boundary data, on a model of the engine's step rather than the engine itself. 1400 particles in
// 2D, each thread owning half of them: a drift over its own (the integrator's first pass), a barrier, a
// pair pass reading four partners per particle (the pair loop), a barrier. A share of the partners lies
// in the other thread's half, as the pairs that cross between the threads' rows do in the engine (3-8 %
// on 1400 disks). Read in place, every such partner costs cache lines that the other core wrote in its
// drift; read from a buffer that the owner fills right after its drift (a ghost copy, as a
// domain-decomposed code sends its boundary), they cost a few contiguous lines. The engine reads them in
// place; this says what a ghost copy would be worth on the machine at hand (in the engine the crossing
// pairs are only part of what two threads lose on small systems: docs/speed.md, "Two threads on small systems").
#include <catch2/catch.hpp>

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <random>
#include <vector>

#include <fmt/format.h>

#include "load_average.hpp"

namespace {

constexpr int particles = 1400, partners = 4;

enum class Exchange { one_thread, in_place, ghost };

struct Model {
  std::vector<double> x, v, vp, f, inverse_mass;
  std::vector<int> partner;                    // partners * particles
  std::vector<std::vector<int>> exported;      // per thread: its particles the other thread reads
  std::vector<std::vector<double>> ghost_x, ghost_vp;
  std::vector<const double*> read_x, read_vp;  // per (particle, partner): where the partner is read
};

int owner(int p) { return p * 2 / particles; }

Model make_model(double cross, Exchange exchange) {
  Model m;
  m.x.assign(2 * particles, 1.0), m.v.assign(2 * particles, 0.1), m.vp.assign(2 * particles, 0.0);
  m.f.assign(2 * particles, 0.01), m.inverse_mass.assign(particles, 1.0);
  m.partner.resize(partners * particles);
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(0, 1);
  std::uniform_int_distribution<int> any(0, particles / 2 - 1);
  for (int i = 0; i < particles; ++i)
    for (int k = 0; k < partners; ++k) {
      const int half = owner(i) * (particles / 2);
      const int near = half + (i - half + 1 + 37 * k) % (particles / 2);   // in i's own half
      m.partner[partners * i + k] = u(rng) < cross ? (particles / 2 - half) + any(rng) : near;
    }
  m.exported.resize(2);
  for (int i = 0; i < particles; ++i)
    for (int k = 0; k < partners; ++k)
      if (const int j = m.partner[partners * i + k]; owner(j) != owner(i)) m.exported[owner(j)].push_back(j);
  std::vector<int> slot(particles, -1);
  for (auto& e : m.exported) {
    std::sort(e.begin(), e.end());
    e.erase(std::unique(e.begin(), e.end()), e.end());
    for (std::size_t g = 0; g < e.size(); ++g) slot[e[g]] = int(g);
  }
  m.ghost_x.resize(2), m.ghost_vp.resize(2);
  for (int t = 0; t < 2; ++t) m.ghost_x[t].resize(2 * m.exported[t].size()), m.ghost_vp[t].resize(2 * m.exported[t].size());
  m.read_x.resize(m.partner.size()), m.read_vp.resize(m.partner.size());
  for (int i = 0; i < particles; ++i)
    for (int k = 0; k < partners; ++k) {
      const int j = m.partner[partners * i + k], e = partners * i + k;
      const bool ghost = exchange == Exchange::ghost && owner(j) != owner(i);
      m.read_x[e] = ghost ? &m.ghost_x[owner(j)][2 * slot[j]] : &m.x[2 * j];
      m.read_vp[e] = ghost ? &m.ghost_vp[owner(j)][2 * slot[j]] : &m.vp[2 * j];
    }
  return m;
}

// Runs `steps` steps; returns the wall microseconds per step and a sum of the final positions.
std::pair<double, double> run(Model& m, Exchange exchange, int steps) {
  const int threads = exchange == Exchange::one_thread ? 1 : 2;
  const double h = 1e-4;
  const auto start = std::chrono::steady_clock::now();
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    const int b = particles * t / threads, e = particles * (t + 1) / threads;
    for (int s = 0; s < steps; ++s) {
      for (int i = b; i < e; ++i)
        for (int c = 0; c < 2; ++c) {
          const int k = 2 * i + c;
          const double a = m.f[k] * m.inverse_mass[i];
          m.v[k] += 0.5 * h * a, m.x[k] += h * m.v[k], m.vp[k] = m.v[k] + 0.5 * h * a;
        }
      if (exchange == Exchange::ghost)
        for (std::size_t g = 0; g < m.exported[t].size(); ++g) {
          const int j = m.exported[t][g];
          for (int c = 0; c < 2; ++c) m.ghost_x[t][2 * g + c] = m.x[2 * j + c], m.ghost_vp[t][2 * g + c] = m.vp[2 * j + c];
        }
#pragma omp barrier
      for (int i = b; i < e; ++i) {
        double sx = 0, sy = 0;
        for (int k = 0; k < partners; ++k) {
          const double* xj = m.read_x[partners * i + k];
          const double* vj = m.read_vp[partners * i + k];
          sx += xj[0] - m.x[2 * i] + vj[0], sy += xj[1] - m.x[2 * i + 1] + vj[1];
        }
        m.f[2 * i] = 1e-3 * sx, m.f[2 * i + 1] = 1e-3 * sy;
      }
#pragma omp barrier
    }
  }
  const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count() / steps;
  double sum = 0;
  for (double c : m.x) sum += c;
  return {us, sum};
}

}  // namespace

TEST_CASE("threads: what two cores pay to exchange a step's boundary data", "[.threads-bench]") {
  const int steps = 40000, rounds = 3;
  // Short lines: Catch wraps its messages at 80 columns.
  WARN(fmt::format("1-min load average {}", load_average()));
  WARN("1400 particles, 4 partners each; microseconds per step (wall clock, medians of 3);\n"
       "crossing: share of partners in the other half; exported: particles read by the other thread");
  WARN("crossing | 1 thread | 2, in place | 2, ghost copy | exported");
  for (double cross : {0.0, 0.03, 0.1}) {
    std::vector<double> us[3];
    double sums[3] = {};
    for (int r = 0; r < rounds; ++r)
      for (Exchange exchange : {Exchange::one_thread, Exchange::in_place, Exchange::ghost}) {
        Model m = make_model(cross, exchange);
        const auto [t, sum] = run(m, exchange, steps);
        us[int(exchange)].push_back(t);
        sums[int(exchange)] = sum;
      }
    // The three ways compute the same thing: the same operations on the same values.
    CHECK(sums[1] == sums[0]);
    CHECK(sums[2] == sums[0]);
    const auto median = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v[v.size() / 2];
    };
    const Model m = make_model(cross, Exchange::in_place);
    WARN(fmt::format("{:8.2f} | {:8.2f} | {:12.2f} | {:13.2f} | {} and {}", cross, median(us[0]), median(us[1]), median(us[2]),
                     m.exported[0].size(), m.exported[1].size()));
  }
}
