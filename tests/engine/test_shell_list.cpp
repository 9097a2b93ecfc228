// The shell of listed pairs near contact (neighbours/shell_list.hpp): it holds exactly the list's entries
// within range + thickness, in list order, with their rows, partners and images (both builds of the pair
// filter); its bound on the list's move is never below the list's own measure, through moves and cell
// strain; and runs with the shell (adaptive, fixed) and without it are the same byte for byte, on one and
// two threads, in a fixed and a deforming cell, with the list rebuilt at the same steps; a restored state
// continues exactly, the shell's counters too.
#include <catch2/catch.hpp>

#include <algorithm>
#include <random>
#include <vector>

#include "core/simulation.hpp"
#include "interactions/pair_filter.hpp"
#include "io/scene.hpp"
#include "neighbours/shell_list.hpp"
#include "packing_scenes.hpp"
#include "random_packing.hpp"

using namespace grains;
using Catch::Contains;

namespace {

template <int D>
void check_selection(const Packing<D>& p, const ShellList<D>& shell, double thickness) {
  const auto& nl = p.list;
  std::size_t m = 0;
  REQUIRE(shell.start.size() == nl.start.size());
  for (std::size_t i = 0; i + 1 < nl.start.size(); ++i) {
    REQUIRE(shell.start[i] == m);
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const std::uint32_t j = nl.partner[k];
      const double reach = p.radius[i] + p.radius[j] + nl.range() + thickness;
      if (!((p.x[j] + nl.shift[nl.image[k]] - p.x[i]).squaredNorm() < reach * reach)) continue;
      REQUIRE(m < shell.pair_count());
      CHECK(shell.entry[m] == k);
      CHECK(shell.owner[m] == i);
      CHECK(shell.partner[m] == j);
      CHECK(shell.image[m] == nl.image[k]);
      ++m;
    }
  }
  CHECK(m == shell.pair_count());
}

template <int D>
void selection_cases() {
  using pair_filter::Isa;
  for (Isa isa : {Isa::avx512, Isa::avx2, Isa::portable}) {   // each capped at what the processor has
    pair_filter::cap_isa(isa);
    for (double range : {0.0, 1e-3})
      for (double thickness : {0.005, 0.05}) {
        const auto p = random_packing<D>(true, range, 3, 0.09);
        ShellList<D> shell;
        shell.configure(thickness, false, 0.2);
        shell.build(p.list, p.x, p.radius, 0.09, 0, false);
        INFO("D = " << D << ", pair loop build " << int(pair_filter::isa()) << ", range " << range << ", thickness " << thickness);
        CHECK(shell.pair_count() > 100);                              // pairs near contact ...
        CHECK(shell.pair_count() + 50 < p.list.pair_count());         // ... not all the listed ones
        check_selection(p, shell, thickness);
      }
  }
  pair_filter::cap_isa(Isa::avx512);
}

// The list's own measure: the largest squared distance from its reference positions as carried.
template <int D>
double list_move(const Packing<D>& p) {
  const auto ref = p.list.reference(p.x.size());
  double largest = 0;
  for (std::size_t i = 0; i < p.x.size(); ++i) {
    const Vec<D> r = ref.lower + (ref.position[i] - ref.lower).cwiseProduct(ref.strain);
    largest = std::max(largest, (p.x[i] - r).squaredNorm());
  }
  return largest;
}

// Moves every particle by up to `move` and strains the cell by `scale` (the particles follow it, as in
// a step), for the list and the shell alike.
template <int D>
void advance(Packing<D>& p, ShellList<D>& shell, double move, const Vec<D>& scale, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g(0, 1);
  for (int a = 0; a < D; ++a) p.box.length[a] *= scale[a];
  p.list.follow_cell(scale, p.box);
  shell.follow_cell(scale, p.box);
  for (auto& x : p.x) {
    Vec<D> d;
    for (int a = 0; a < D; ++a) d[a] = g(rng);
    x += move * u(rng) * d.normalized();
    x = p.box.lower + (x - p.box.lower).cwiseProduct(scale);
  }
}

template <int D>
void bound_cases() {
  std::mt19937_64 rng(11);
  auto p = random_packing<D>(true, 1e-3, 5, 0.0);
  ShellList<D> shell;
  shell.configure(0.01, false, 0.2);
  shell.build(p.list, p.x, p.radius, 0.0, 0, false);
  int shells = 0;
  for (int round = 0; round < 40; ++round) {
    Vec<D> scale;
    for (int a = 0; a < D; ++a) scale[a] = 1 + (a % 2 ? -1 : 1) * 2e-4;   // one axis grows, the next shrinks
    advance(p, shell, 0.002, scale, rng);
    // The shell's own measure: the distance from its reference positions, carried.
    const auto ref = shell.reference(p.x.size());
    REQUIRE(ref.position);
    double moved = 0;
    for (std::size_t i = 0; i < p.x.size(); ++i)
      moved = std::max(moved, (p.x[i] - (ref.lower + (ref.position[i] - ref.lower).cwiseProduct(ref.strain))).squaredNorm());
    const double exact = list_move(p);
    INFO("round " << round);
    CHECK(shell.list_move_bound(moved) >= exact);
    CHECK(shell.list_move_bound(moved) < 4 * exact + 1e-6);   // a bound, not a blanket
    if (shell.stale_after(moved)) shell.build(p.list, p.x, p.radius, std::sqrt(exact), round, true), ++shells;
  }
  CHECK(shells >= 5);   // the shell was selected again several times over the list's life
}

struct Run {
  std::vector<std::byte> state;
  double list_builds, shell_builds, shell_pairs;
};

// The run's state restored into the same scene without a shell and saved again: everything but the
// shell, byte for byte.
Run run(const Scene& scene, const Scene& without_shell, long steps) {
  auto s = Simulation::create(scene);
  s->step_n(steps);
  const auto state = s->save_state();
  auto plain = Simulation::create(without_shell);
  plain->restore_state(state);
  return {plain->save_state(), s->get("neighbour_builds"), s->get("shell_builds"), s->get("shell_pairs")};
}

}  // namespace

TEST_CASE("shell list: exactly the listed pairs within range + thickness, in list order (2D)", "[shell]") { selection_cases<2>(); }

TEST_CASE("shell list: exactly the listed pairs within range + thickness, in list order (3D)", "[shell]") { selection_cases<3>(); }

TEST_CASE("shell list: its bound on the list's move never falls below the list's measure", "[shell]") {
  bound_cases<2>();
  bound_cases<3>();
}

TEST_CASE("shell list: runs with and without the shell are the same byte for byte", "[shell]") {
  for (int threads : {1, 2})
    for (bool affine : {true, false}) {
      INFO("cohesive disks, threads " << threads << ", deforming cell " << affine);
      const Scene plain = compressed_packing(threads, 0.005, affine, "[neighbours]\nshell = 0\n");
      const Run adaptive = run(compressed_packing(threads, 0.005, affine), plain, 20000);
      const Run fixed = run(compressed_packing(threads, 0.005, affine, "[neighbours]\nshell = 0.003\n"), plain, 20000);
      const Run none = run(plain, plain, 20000);
      CHECK(adaptive.shell_builds > 20);   // the shell was selected again and again
      CHECK(fixed.shell_builds > 20);
      CHECK(adaptive.shell_pairs > 0);
      CHECK(none.shell_builds == 0);
      CHECK(adaptive.list_builds > 2);     // and the list rebuilt several times, at the same steps
      CHECK(adaptive.list_builds == none.list_builds);
      CHECK(fixed.list_builds == none.list_builds);
      CHECK(adaptive.state == none.state);
      CHECK(fixed.state == none.state);
    }
  for (double mu : {0.0, 0.5}) {
    INFO("hot spheres, mu " << mu);
    const Scene plain = hot_spheres(2, true, mu, "[neighbours]\nshell = 0\n");
    const Run adaptive = run(hot_spheres(2, true, mu), plain, 2000);
    const Run none = run(plain, plain, 2000);
    CHECK(adaptive.shell_builds > 20);
    CHECK(adaptive.list_builds == none.list_builds);
    CHECK(adaptive.state == none.state);
  }
}

TEST_CASE("shell list: a restored state continues exactly, the shell's counters included", "[shell]") {
  const Scene scene = compressed_packing(1, 0.005, true);
  auto a = Simulation::create(scene);
  a->step_n(5000);
  const auto state = a->save_state();
  a->step_n(5000);
  auto b = Simulation::create(scene);
  b->restore_state(state);
  b->step_n(5000);
  CHECK(a->get("shell_builds") > 10);
  for (const char* name : {"shell_builds", "shell_pairs", "shell_thickness", "neighbour_builds"}) CHECK(a->get(name) == b->get(name));
  CHECK(a->save_state() == b->save_state());
}

TEST_CASE("shell list: a shell as thick as the skin is refused, naming both", "[shell][scene][errors]") {
  REQUIRE_THROWS_WITH(Simulation::create(hot_spheres(1, false, 0.0, "[neighbours]\nskin = 0.1\nshell = 0.1\n")),
                      Contains("neighbours.shell") && Contains("0.1") && Contains("skin"));
  REQUIRE_NOTHROW(Simulation::create(hot_spheres(1, false, 0.0, "[neighbours]\nskin = 0.1\nshell = 0.05\n")));
}
