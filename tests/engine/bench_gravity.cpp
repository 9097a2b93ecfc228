// Benchmarks, hidden from the suite (run: grains_tests "[.gravity-bench]", which also runs the n_c table of
// bench_steps_per_contact.cpp): the tables docs/speed.md quotes. Uniform balls of N equal masses, eps = 1e-3
// (radius 1). All numbers from one run, so the ratios compare like with like on a shared machine.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <functional>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "gravity_inputs.hpp"
#include "interactions/gravity.hpp"
#include "interactions/gravity_direct.hpp"
#include "interactions/gravity_tree.hpp"
#include "load_average.hpp"

using namespace grains;

namespace {
// The fastest of at least `min_calls` calls lasting `min_seconds` in all: on the shared machine a call
// slows down whenever another process takes one of the threads' cores, so the fastest call is the least
// disturbed one.
template <class F> double seconds_per_call(F&& f, double min_seconds = 0.3, int min_calls = 3) {
  f();   // warm-up (first touch of the memory, thread start-up)
  double total = 0, fastest = 1e300;
  for (int reps = 0; reps < min_calls || total < min_seconds; ++reps) {
    const auto t0 = std::chrono::steady_clock::now();
    f();
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    total += s, fastest = std::min(fastest, s);
  }
  return fastest;
}
// Median and 99th percentile of |a - ref| / |ref|.
std::pair<double, double> force_errors(const std::vector<Vec<3>>& a, const std::vector<Vec<3>>& ref) {
  std::vector<double> e(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) e[i] = (a[i] - ref[i]).norm() / ref[i].norm();
  std::sort(e.begin(), e.end());
  return {e[e.size() / 2], e[std::size_t(0.99 * double(e.size() - 1))]};
}
}  // namespace

TEST_CASE("gravity: direct kernel throughput", "[.gravity-bench]") {
  // Softened pair interactions N (N - 1) per second (FP64 forces), each kernel set the CPU runs on 1 and 2
  // threads, the portable one on 1 thread only. The variants take turns call by call, and each keeps its
  // fastest call, so that they meet the same load; per CPU second too (the calling thread's CPU time on 1
  // thread, the process's on 2), and the load average before and after, as the machine is shared.
  const double eps = 1e-3;
  using gravity_direct::Isa;
  WARN(fmt::format("direct summation, FP64 forces, pair interactions N (N - 1) per second (the module runs the {} "
                   "kernels; 1-min load average {}):", gravity_direct::isa_name(gravity_direct::fastest_isa()), load_average()));
  struct Variant {
    Isa isa;
    int threads;
    double wall = 1e300, cpu = 1e300;
  };
  std::vector<Variant> variants;
  for (int threads : {1, 2})
    for (auto isa : runnable_isas())
      if (isa != Isa::portable || threads == 1) variants.push_back({isa, threads});
  auto now = [](clockid_t clock) {
    timespec t;
    clock_gettime(clock, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
  };
  for (int n : {1000, 2000, 5000, 10000, 20000}) {
    const auto P = particles_from<3>(uniform_ball(n, 1.0, 1), 1.0 / n);
    const gravity_direct::Columns c(P);
    std::vector<double> ax, ay, az;
    const double pairs = double(n) * (n - 1);
    for (auto& v : variants) v.wall = v.cpu = 1e300, gravity_direct::accelerations(v.isa, c, eps * eps, v.threads, ax, ay, az);
    // Rounds until the slowest variant has run about 1 s in all (at least 3 rounds).
    double slowest = 0;
    for (int round = 0; round < 3 || slowest * round < 1.0; ++round) {
      slowest = 0;
      for (auto& v : variants) {
        const clockid_t clock = v.threads == 1 ? CLOCK_THREAD_CPUTIME_ID : CLOCK_PROCESS_CPUTIME_ID;
        const double w0 = now(CLOCK_MONOTONIC), c0 = now(clock);
        gravity_direct::accelerations(v.isa, c, eps * eps, v.threads, ax, ay, az);
        const double w = now(CLOCK_MONOTONIC) - w0;
        v.wall = std::min(v.wall, w), v.cpu = std::min(v.cpu, now(clock) - c0), slowest = std::max(slowest, w);
      }
    }
    std::string line = fmt::format("  N = {:6}:", n);
    for (const auto& v : variants)
      line += fmt::format(" {} {} thr {:.3g} /s ({:.3g} per CPU s);", gravity_direct::isa_name(v.isa), v.threads, pairs / v.wall,
                          pairs / v.cpu);
    WARN(line);
  }
  WARN(fmt::format("  1-min load average after: {}", load_average()));
}

TEST_CASE("gravity: tree against direct summation", "[.gravity-bench]") {
  const double eps = 1e-3;
  WARN(fmt::format("1-min load average {}", load_average()));
  // 1. Tree (theta = 0.5) against direct, 2 threads: the crossover N and the speed-up at 1e4, 3e4 and 1e5, with
  //    the tree's force error beside it.
  WARN(fmt::format("tree (theta 0.5) against direct, 2 threads, the {} kernels: seconds per force evaluation; tree force "
                   "error median / 99th pct", gravity_direct::isa_name(gravity_direct::fastest_isa())));
  int crossover = -1;
  for (int n : {125, 250, 500, 1000, 2000, 4000, 10000, 30000, 100000}) {
    const auto P = particles_from<3>(uniform_ball(n, 1.0, 3), 1.0 / n);
    SoftenedGravity<3> g(1.0, eps, GravitySolver::tree, 0.5);
    std::vector<Vec<3>> direct, tree;
    const bool big = n > 30000;   // one direct call is enough there (about 10 s)
    const double sd = big ? seconds_per_call([&] { direct = g.accelerations(P, GravitySolver::direct, 2); }, 0.0, 1)
                          : seconds_per_call([&] { direct = g.accelerations(P, GravitySolver::direct, 2); });
    const double st = seconds_per_call([&] { tree = g.accelerations(P, GravitySolver::tree, 2); });
    const auto [median, p99] = force_errors(tree, direct);
    if (st >= sd) crossover = -1;
    else if (crossover < 0) crossover = n;
    WARN(fmt::format("  N = {:6}: direct {:.3g} s, tree {:.3g} s, direct / tree {:.2f}; error {:.2g} / {:.2g}", n, sd, st,
                     sd / st, median, p99));
  }
  WARN(fmt::format("  crossover: the tree is faster from N = {} on (it wins there and at every larger N of the list)", crossover));
  // 2. N = 3e5, tree only; its error against direct sums for 1000 of the particles.
  {
    const int n = 300000, probes = 1000;
    const auto P = particles_from<3>(uniform_ball(n, 1.0, 5), 1.0 / n);
    SoftenedGravity<3> g(1.0, eps, GravitySolver::tree, 0.5);
    std::vector<Vec<3>> tree, a, ref;
    const double st = seconds_per_call([&] { tree = g.accelerations(P, GravitySolver::tree, 2); });
    for (int k = 0; k < probes; ++k) {
      const std::size_t i = std::size_t(k) * (n / probes);
      Vec<3> s = Vec<3>::Zero();
      for (int j = 0; j < n; ++j) {
        const Vec<3> r = P.position[j] - P.position[i];
        if (std::size_t(j) != i) s += P.mass[j] * r / std::pow(r.squaredNorm() + eps * eps, 1.5);
      }
      a.push_back(tree[i]), ref.push_back(s);
    }
    const auto [median, p99] = force_errors(a, ref);
    WARN(fmt::format("N = 3e5, 2 threads: tree (theta 0.5) {:.3f} s; force error on {} particles median {:.2g}, 99th "
                     "percentile {:.2g}", st, probes, median, p99));
  }
  // 3. Speed/accuracy of theta, N = 20000, against direct summation (theta -> 0).
  {
    const int n = 20000;
    const auto P = particles_from<3>(uniform_ball(n, 1.0, 4), 1.0 / n);
    SoftenedGravity<3> g0(1.0, eps, GravitySolver::direct);
    std::vector<Vec<3>> direct;
    const double sd = seconds_per_call([&] { direct = g0.accelerations(P, GravitySolver::direct, 2); });
    WARN(fmt::format("theta table, N = {}, 2 threads (direct: {:.3g} s): theta | s per evaluation | cost / direct | "
                     "median error | 99th percentile error", n, sd));
    for (double theta : {0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 1.0}) {
      SoftenedGravity<3> g(1.0, eps, GravitySolver::tree, theta);
      std::vector<Vec<3>> tree;
      const double st = seconds_per_call([&] { tree = g.accelerations(P, GravitySolver::tree, 2); });
      const auto [median, p99] = force_errors(tree, direct);
      WARN(fmt::format("  {:.1f} | {:.3g} | {:.3f} | {:.2g} | {:.2g}", theta, st, st / sd, median, p99));
    }
  }
}

TEST_CASE("gravity: tree levers (leaf size, kernel, threads, build share)", "[.gravity-bench]") {
  // N = 1e5 uniform ball, theta = 0.5, eps = 1e-3: build and walk times (fastest of a few calls), the terms
  // summed per particle and the error against direct summation, for each leaf size; then every kernel set
  // the CPU runs, on 1 and 2 threads, at the default leaf size.
  const int n = 100000;
  const double eps = 1e-3, theta = 0.5;
  const auto P = particles_from<3>(uniform_ball(n, 1.0, 2), 1.0 / n);
  SoftenedGravity<3> g(1.0, eps, GravitySolver::direct);
  const auto direct = g.accelerations(P, GravitySolver::direct, 2);
  WARN(fmt::format("tree levers, N = 1e5, theta 0.5 (1-min load average {}): leaf size | group size | isa | threads | build s | walk s "
                   "| particle terms / N | cell terms / N | median error | 99th pct", load_average()));
  auto row = [&](int leaf, int group, gravity_direct::Isa isa, int threads) {
    std::vector<double> ax, ay, az;
    gravity_tree::Tree::Counts counts;
    const double sb = seconds_per_call([&] { gravity_tree::Tree(P, theta, threads, leaf, group); }, 0.1);
    const gravity_tree::Tree tree(P, theta, threads, leaf, group);
    const double sw = seconds_per_call([&] { counts = tree.evaluate(isa, eps * eps, threads, ax, ay, az, nullptr); }, 0.1);
    std::vector<Vec<3>> a(n);
    for (int i = 0; i < n; ++i) a[i] = Vec<3>(ax[i], ay[i], az[i]);
    const auto [median, p99] = force_errors(a, direct);
    WARN(fmt::format("  {:3} | {:3} | {} | {} | {:.3g} | {:.3g} | {:.0f} | {:.0f} | {:.2g} | {:.2g}", leaf, group,
                     gravity_direct::isa_name(isa), threads, sb, sw,
                     double(counts.particle_pairs) / n, double(counts.particle_cells) / n, median, p99));
  };
  const auto fastest = gravity_direct::fastest_isa();
  for (int leaf : {8, 16, 32})
    for (int group : {leaf, 32, 64, 128, 256})
      if (group >= leaf) row(leaf, group, fastest, 2);
  for (auto isa : runnable_isas())
    for (int threads : {1, 2}) row(16, 64, isa, threads);
}

TEST_CASE("gravity: kernel sets at N = 1e5 (direct and tree)", "[.gravity-bench]") {
  // Uniform ball, eps = 1e-3: direct summation (2 threads) and the walk of one tree (theta 0.5, built once;
  // 1 and 2 threads) with each vector kernel set the CPU runs. The variants take turns call by call and each
  // keeps its fastest call (wall) and least CPU time (the process's, all threads), as the machine is shared.
  const int n = 100000;
  const double eps2 = 1e-6;
  using gravity_direct::Isa;
  const auto P = particles_from<3>(uniform_ball(n, 1.0, 2), 1.0 / n);
  const gravity_direct::Columns c(P);
  const gravity_tree::Tree tree(P, 0.5);
  std::vector<Isa> isas;
  for (auto isa : runnable_isas())
    if (isa != Isa::portable) isas.push_back(isa);
  auto now = [](clockid_t clock) {
    timespec t;
    clock_gettime(clock, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
  };
  // Fastest wall and least CPU seconds of `rounds` turns of each variant.
  auto turns = [&](int rounds, const std::vector<std::function<void()>>& variants) {
    std::vector<std::pair<double, double>> best(variants.size(), {1e300, 1e300});
    for (int r = 0; r < rounds; ++r)
      for (std::size_t k = 0; k < variants.size(); ++k) {
        const double w0 = now(CLOCK_MONOTONIC), c0 = now(CLOCK_PROCESS_CPUTIME_ID);
        variants[k]();
        best[k].first = std::min(best[k].first, now(CLOCK_MONOTONIC) - w0);
        best[k].second = std::min(best[k].second, now(CLOCK_PROCESS_CPUTIME_ID) - c0);
      }
    return best;
  };
  std::vector<double> ax, ay, az;
  WARN(fmt::format("N = 1e5, kernel sets (1-min load average {}):", load_average()));
  std::vector<std::function<void()>> direct, walk1, walk2;
  for (auto isa : isas) {
    direct.push_back([&, isa] { gravity_direct::accelerations(isa, c, eps2, 2, ax, ay, az); });
    walk1.push_back([&, isa] { tree.evaluate(isa, eps2, 1, ax, ay, az, nullptr); });
    walk2.push_back([&, isa] { tree.evaluate(isa, eps2, 2, ax, ay, az, nullptr); });
  }
  const auto d = turns(2, direct), w1 = turns(5, walk1), w2 = turns(5, walk2);
  const double pairs = double(n) * (n - 1);
  for (std::size_t k = 0; k < isas.size(); ++k)
    WARN(fmt::format("  {}: direct, 2 threads {:.3g} s ({:.3g} pairs /s, {:.3g} per CPU s); tree walk, 1 thread {:.3g} s "
                     "({:.3g} CPU s), 2 threads {:.3g} s ({:.3g} CPU s); direct / tree walk (2 threads) {:.0f}",
                     gravity_direct::isa_name(isas[k]), d[k].first, pairs / d[k].first, pairs / d[k].second, w1[k].first,
                     w1[k].second, w2[k].first, w2[k].second, d[k].first / w2[k].first));
  WARN(fmt::format("  1-min load average after: {}", load_average()));
}
