// NeighbourList<D> against the O(N^2) brute force: the exact pair set (gap < skin) with the stored
// periodic image, for size ratio up to 10 (uniform and bimodal), open and periodic boxes (including
// small, non-cubic, offset ones), D = 2 and 3, several seeds, 1 and 2 threads and the portable and
// AVX-512 candidate tests (identical lists);
// contacts stay listed while particles move less than skin/2; carry() maps per-pair values.
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "interactions/pair_filter.hpp"
#include "neighbours/neighbour_list.hpp"

using namespace grains;

namespace {

enum class Sizes { mono, uniform, bimodal };

template <int D>
struct Config {
  std::vector<Vec<D>> x;
  std::vector<double> radius;
  Box<D> box;
  std::string label;
};

// Diameters in [0.1, 1]: uniform, or bimodal (a third large, 1.0, the rest small, 0.1). Positions
// uniform in the box (overlaps are allowed: the list is geometry only); open boxes are offset
// to negative coordinates.
template <int D>
Config<D> make_config(std::size_t n, Sizes sizes, bool periodic, double edge, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Config<D> c;
  for (int a = 0; a < D; ++a) {
    c.box.length[a] = edge * (1.0 + 0.15 * a);   // non-cubic
    c.box.lower[a] = -0.3 * edge + 0.7 * a;
    c.box.periodic[a] = periodic;
  }
  for (std::size_t i = 0; i < n; ++i) {
    Vec<D> p;
    for (int a = 0; a < D; ++a) p[a] = c.box.lower[a] + u(rng) * c.box.length[a];
    c.x.push_back(p);
    double d = 1.0;
    if (sizes == Sizes::uniform) d = 0.1 + 0.9 * u(rng);
    if (sizes == Sizes::bimodal) d = u(rng) < 1.0 / 3 ? 1.0 : 0.1;
    c.radius.push_back(0.5 * d);
  }
  c.label = "D = " + std::to_string(D) + ", sizes " + std::to_string(int(sizes)) + ", periodic " +
            std::to_string(periodic) + ", edge " + std::to_string(edge) + ", seed " + std::to_string(seed);
  return c;
}

// Moves a periodic configuration as between two list builds: a uniform drift across the periodic
// boundary (images change, pairs persist), plus a random displacement of a third of the particles
// (some pairs leave, some arrive).
template <int D>
void drift_and_jostle(Config<D>& c, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (std::size_t i = 0; i < c.x.size(); ++i) {
    c.x[i][0] += 0.37 * c.box.length[0];
    if (i % 3 == 0)
      for (int a = 0; a < D; ++a) c.x[i][a] += 0.5 * u(rng);
    c.x[i] = c.box.wrap(c.x[i]);
  }
}

// A pair (i < j) and the integer periodic image k (pair vector = x_j - x_i + k L).
using Entry = std::tuple<std::size_t, std::size_t, std::array<int, 3>>;

template <int D>
std::array<int, 3> image_of(const Box<D>& box, const Vec<D>& raw, const Vec<D>& used) {
  std::array<int, 3> k{0, 0, 0};
  for (int a = 0; a < D; ++a) k[a] = int(std::lround((used[a] - raw[a]) / box.length[a]));
  return k;
}

template <int D>
std::set<Entry> brute_force(const Config<D>& c, double reach) {
  std::set<Entry> s;
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (std::size_t j = i + 1; j < c.x.size(); ++j) {
      const Vec<D> raw = c.x[j] - c.x[i];
      const Vec<D> r = c.box.minimum_image(raw);
      if (r.norm() - c.radius[i] - c.radius[j] < reach) s.emplace(i, j, image_of(c.box, raw, r));
    }
  return s;
}

template <int D>
std::set<Entry> listed(const Config<D>& c, const NeighbourList<D>& nl) {
  std::set<Entry> s;
  REQUIRE(nl.start.size() == c.x.size() + 1);
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const std::size_t j = nl.partner[k];
      CHECK(j > i);
      const Vec<D> raw = c.x[j] - c.x[i];
      const bool inserted = s.emplace(i, j, image_of(c.box, raw, Vec<D>(raw + nl.shift[nl.image[k]]))).second;
      CHECK(inserted);   // no pair twice
    }
  return s;
}

template <int D>
void check_exact(const Config<D>& c, double skin) {
  const auto expected = brute_force(c, skin);
  NeighbourList<D> one, two;
  one.configure(0.0, skin);
  two.configure(0.0, skin);
  one.build(c.x, c.radius, c.box, 1);
  two.build(c.x, c.radius, c.box, 2);
  INFO(c.label << ", skin " << skin << ": " << expected.size() << " brute-force pairs");
  CHECK(expected.size() > 30);
  const auto got = listed(c, one);
  CHECK(got.size() == expected.size());
  std::vector<Entry> missing, extra;
  for (const auto& e : expected)
    if (!got.count(e)) missing.push_back(e);
  for (const auto& e : got)
    if (!expected.count(e)) extra.push_back(e);
  CHECK(missing.empty());
  CHECK(extra.empty());
  // Two threads: the very same arrays.
  CHECK(one.start == two.start);
  CHECK(one.partner == two.partner);
  CHECK(one.image == two.image);
  // The portable candidate test (what a processor without AVX-512 runs): the very same arrays too.
  NeighbourList<D> portable;
  portable.configure(0.0, skin);
  pair_filter::cap_isa(pair_filter::Isa::portable);
  portable.build(c.x, c.radius, c.box, 1);
  pair_filter::cap_isa(pair_filter::Isa::avx512);
  CHECK(one.start == portable.start);
  CHECK(one.partner == portable.partner);
  CHECK(one.image == portable.image);
}

template <int D>
void exact_set_cases() {
  const std::size_t n = D == 3 ? 700 : 350;
  for (unsigned seed : {1u, 7u, 42u})
    for (Sizes sizes : {Sizes::mono, Sizes::uniform, Sizes::bimodal}) {
      // Density chosen so that every case has a few hundred pairs.
      const double edge = D == 3 ? 9.0 : 13.0;
      check_exact(make_config<D>(n, sizes, false, edge, seed), 0.12);
      check_exact(make_config<D>(n, sizes, true, edge, seed), 0.12);
      // A small periodic box: only 2-3 cells per axis for the large class (duplicate neighbour cells).
      check_exact(make_config<D>(D == 3 ? 60 : 40, sizes, true, 3.0, seed), 0.2);
    }
}

}  // namespace

TEST_CASE("neighbour list: the pair set and periodic images equal brute force (3D)", "[neighbours]") {
  exact_set_cases<3>();
}

TEST_CASE("neighbour list: the pair set and periodic images equal brute force (2D)", "[neighbours]") {
  exact_set_cases<2>();
}

// Grains flung far from the rest (ejected from a rubble pile): in an open box, and in one open along the
// last axis only (a chute). The list holds exactly the brute-force pairs (a touching pair out there too;
// up to 1e18 away, where the keys' rounding is hundreds of reaches), and, up to 1e12, the build tests a
// number of candidates linear in N: a grid spanning the extent, coarsened to its
// cell budget, put the whole cluster into a few cells (N^2 / 2 candidates, 1000 N here).
template <int D>
void far_grain_cases() {
  const std::size_t n = D == 3 ? 2000 : 1000;
  for (Sizes sizes : {Sizes::mono, Sizes::bimodal})
    for (int periodic_axes : {0, D - 1})
      for (double far : {1e5, 30.0, 1e12, 3e15, 1e17, 1e18}) {
        auto c = make_config<D>(n, sizes, false, D == 3 ? 13.0 : 22.0, 5);
        Vec<D> middle;
        for (int a = 0; a < D; ++a) {
          c.box.periodic[a] = a < periodic_axes;
          middle[a] = c.box.lower[a] + 0.5 * c.box.length[a];
        }
        Vec<D> out = middle, pair = middle;
        for (int a = periodic_axes; a < D; ++a) out[a] = far, pair[a] = -0.7 * far;
        c.x.push_back(out), c.radius.push_back(0.5);
        c.x.push_back(pair), c.radius.push_back(0.5);
        pair[0] += 0.9;
        c.x.push_back(pair), c.radius.push_back(0.5);
        c.label += ", periodic axes " + std::to_string(periodic_axes) + ", far " + std::to_string(far);
        check_exact(c, 0.12);
        NeighbourList<D> nl;
        nl.configure(0.0, 0.12);
        nl.build(c.x, c.radius, c.box, 2);
        INFO(c.label << ": " << nl.candidates_examined() << " candidates tested for " << c.x.size() << " particles");
        // Linear while the keys' rounding is far below a cell (past ~1e15 reaches the cells widen: exact only).
        if (far <= 1e12) CHECK(nl.candidates_examined() < 50 * c.x.size());
      }
}

TEST_CASE("neighbour list: grains far from the rest give the brute-force pairs in a linear build (3D)", "[neighbours]") {
  far_grain_cases<3>();
}

TEST_CASE("neighbour list: grains far from the rest give the brute-force pairs in a linear build (2D)", "[neighbours]") {
  far_grain_cases<2>();
}

// The engine's staleness test: the step's pass measures the largest squared move from the list's
// reference positions (core/integrator.hpp), the list judges it.
template <int D>
bool stale(const NeighbourList<D>& nl, const std::vector<Vec<D>>& x) {
  const auto reference = nl.reference(x.size());
  REQUIRE(reference.position);
  double largest = 0;
  for (std::size_t i = 0; i < x.size(); ++i) largest = std::max(largest, (x[i] - reference.position[i]).squaredNorm());
  return nl.stale_after(largest);
}

template <int D>
void moves_below_half_skin(Sizes sizes, bool periodic, unsigned seed) {
  auto c = make_config<D>(D == 3 ? 700 : 350, sizes, periodic, D == 3 ? 9.0 : 13.0, seed);
  const double skin = 0.2;
  NeighbourList<D> nl;
  nl.configure(0.0, skin);
  nl.build(c.x, c.radius, c.box, 2);
  const auto at_build = c.x;
  // Move every particle by just under skin/2 in a random direction (positions are not re-wrapped,
  // exactly as between two builds in the engine). Worst case: two particles close by 2 * 0.4995 skin.
  std::mt19937_64 rng(seed + 100);
  std::normal_distribution<double> g(0, 1);
  for (auto& p : c.x) {
    Vec<D> d;
    for (int a = 0; a < D; ++a) d[a] = g(rng);
    p += 0.4995 * skin * d.normalized();
  }
  INFO(c.label);
  REQUIRE_FALSE(stale(nl, c.x));
  // Every touching pair (brute force on the moved positions) is listed, and the stored image
  // gives the touching separation.
  std::size_t touching = 0;
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (std::size_t j = i + 1; j < c.x.size(); ++j) {
      const double rsum = c.radius[i] + c.radius[j];
      if (c.box.minimum_image(Vec<D>(c.x[j] - c.x[i])).norm() >= rsum) continue;
      ++touching;
      bool found = false;
      for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k)
        if (nl.partner[k] == j) found = (c.x[j] + nl.shift[nl.image[k]] - c.x[i]).norm() < rsum;
      INFO("pair " << i << ", " << j);
      CHECK(found);
    }
  CHECK(touching > 20);
  // One particle a little further than skin/2 from where it was at the build: the list is stale.
  auto moved = c.x;
  Vec<D> step = Vec<D>::Zero();
  step[0] = 0.5 * skin * 1.01;
  moved[3] = at_build[3] + step;
  CHECK(stale(nl, moved));
  moved[3] = at_build[3], moved[moved.size() - 3] = at_build[moved.size() - 3] + step;   // in the second share
  CHECK(stale(nl, moved));
}

TEST_CASE("neighbour list: every contact stays listed while particles move less than skin/2", "[neighbours]") {
  for (unsigned seed : {3u, 11u})
    for (bool periodic : {false, true}) {
      moves_below_half_skin<3>(Sizes::uniform, periodic, seed);
      moves_below_half_skin<3>(Sizes::bimodal, periodic, seed);
      moves_below_half_skin<2>(Sizes::uniform, periodic, seed);
      moves_below_half_skin<2>(Sizes::bimodal, periodic, seed);
    }
}

template <int D>
void carry_case(Sizes sizes, unsigned seed) {
  auto c = make_config<D>(D == 3 ? 600 : 300, sizes, true, D == 3 ? 9.0 : 13.0, seed);
  const double skin = 0.2;
  NeighbourList<D> nl;
  nl.configure(0.0, skin, true);
  nl.build(c.x, c.radius, c.box, 1);
  std::vector<double> value(nl.pair_count());
  std::map<std::pair<std::size_t, std::size_t>, double> by_pair;
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) value[k] = by_pair[{i, nl.partner[k]}] = 1000.0 + k;
  drift_and_jostle(c, seed);
  std::vector<std::uint8_t> old_image = nl.image;
  for (int threads : {1, 2}) {
    NeighbourList<D> again = nl;   // same previous list, rebuilt with 1 or 2 threads
    again.build(c.x, c.radius, c.box, threads);
    std::vector<double> carried = value;
    again.carry(carried, -1.0);
    REQUIRE(carried.size() == again.pair_count());
    std::size_t kept = 0, fresh = 0;
    for (std::size_t i = 0; i < c.x.size(); ++i)
      for (auto k = again.start[i]; k < again.start[i + 1]; ++k) {
        auto it = by_pair.find({i, again.partner[k]});
        INFO(c.label << ", threads " << threads << ", pair " << i << ", " << again.partner[k]);
        if (it != by_pair.end()) {
          CHECK(carried[k] == it->second);
          ++kept;
        } else {
          CHECK(carried[k] == -1.0);
          ++fresh;
        }
      }
    INFO(c.label << ": kept " << kept << ", fresh " << fresh);
    CHECK(kept > 100);
    CHECK(fresh > 10);
  }
}

TEST_CASE("neighbour list: carry() maps per-pair values across a rebuild, new pairs get the fresh value", "[neighbours]") {
  for (unsigned seed : {5u, 6u}) {
    carry_case<3>(Sizes::uniform, seed);
    carry_case<3>(Sizes::bimodal, seed);
    carry_case<2>(Sizes::uniform, seed);
    carry_case<2>(Sizes::bimodal, seed);
  }
}

// Without history the build neither sorts rows nor maps entries to the previous list, so carrying
// values across it would silently scramble them: carry() refuses (match_previous() is the way there).
TEST_CASE("neighbour list: carry() needs a list configured with history", "[neighbours]") {
  auto c = make_config<3>(200, Sizes::uniform, true, 6.0, 9);
  NeighbourList<3> nl;
  nl.configure(0.0, 0.2);
  nl.build(c.x, c.radius, c.box, 1);
  std::vector<double> value(nl.pair_count(), 1.0);
  CHECK_THROWS_AS(nl.carry(value, 0.0), std::logic_error);
  nl.configure(0.0, 0.2, true);
  nl.build(c.x, c.radius, c.box, 1);
  CHECK_NOTHROW(nl.carry(value, 0.0));
}

// match_previous() on a list without history (rows in discovery order, unsorted): every selected
// previous entry that is listed again is handed over once, at the entry of the same pair; selected
// entries of pairs that left, and unselected ones, are not.
template <int D>
void match_previous_case(unsigned seed) {
  auto c = make_config<D>(D == 3 ? 600 : 300, Sizes::uniform, true, D == 3 ? 9.0 : 13.0, seed);
  NeighbourList<D> nl;
  nl.configure(0.0, 0.2);
  nl.build(c.x, c.radius, c.box, 1);
  std::vector<std::pair<std::size_t, std::size_t>> old_pair(nl.pair_count());
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) old_pair[k] = {i, nl.partner[k]};
  drift_and_jostle(c, seed);
  nl.build(c.x, c.radius, c.box, 2);
  std::map<std::pair<std::size_t, std::size_t>, std::size_t> now;   // pair -> entry
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) now[{i, nl.partner[k]}] = k;
  auto selected = [](std::size_t old) { return old % 3 != 1; };
  std::vector<int> calls(old_pair.size(), 0);
  std::size_t moved = 0, expected = 0;
  nl.match_previous(selected, [&](std::size_t old, std::size_t k) {
    ++calls[old], ++moved;
    INFO("previous entry " << old << " -> " << k);
    CHECK(selected(old));
    CHECK(now.at(old_pair[old]) == k);
  });
  for (std::size_t old = 0; old < old_pair.size(); ++old) {
    const bool listed = now.count(old_pair[old]) > 0;
    expected += selected(old) && listed;
    CHECK(calls[old] == (selected(old) && listed ? 1 : 0));
  }
  CHECK(moved == expected);
  CHECK(expected > 100);
  CHECK(expected < old_pair.size() * 2 / 3);   // some selected pairs left the list
}

TEST_CASE("neighbour list: match_previous() hands selected entries to the same pairs after a rebuild", "[neighbours]") {
  for (unsigned seed : {5u, 6u}) {
    match_previous_case<3>(seed);
    match_previous_case<2>(seed);
  }
}
