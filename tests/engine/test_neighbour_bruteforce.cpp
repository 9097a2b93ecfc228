// The neighbour list holds exactly the brute-force pair set, for polydisperse systems in open and
// periodic boxes, in 2D and 3D, on one and two threads.
#include <catch2/catch.hpp>

#include <map>
#include <random>
#include <set>
#include <tuple>

#include "neighbours/neighbour_list.hpp"

using namespace grains;

namespace {

template <int D>
struct Config {
  std::vector<Vec<D>> x;
  std::vector<double> radius;
  Box<D> box;
};

template <int D>
Config<D> random_config(std::size_t n, double dmin, double dmax, bool periodic, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Config<D> c;
  c.box.length.setConstant(12.0);
  for (int a = 0; a < D; ++a) c.box.periodic[a] = periodic;
  for (std::size_t i = 0; i < n; ++i) {
    Vec<D> p;
    for (int a = 0; a < D; ++a) p[a] = u(rng) * 12.0;
    c.x.push_back(p);
    c.radius.push_back(0.5 * (dmin + (dmax - dmin) * u(rng)));
  }
  return c;
}

// (i, j) with i < j, and the pair vector rounded to detect the wrong periodic image.
using PairSet = std::set<std::tuple<std::size_t, std::size_t, long, long, long>>;

template <int D>
PairSet brute_force(const Config<D>& c, double reach) {
  PairSet s;
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (std::size_t j = i + 1; j < c.x.size(); ++j) {
      Vec<D> r = c.box.minimum_image(c.x[j] - c.x[i]);
      if (r.norm() < c.radius[i] + c.radius[j] + reach)
        s.emplace(i, j, std::lround(r[0] * 1e6), std::lround(r[1] * 1e6), D == 3 ? std::lround(r[D - 1] * 1e6) : 0);
    }
  return s;
}

template <int D>
PairSet from_list(const Config<D>& c, const NeighbourList<D>& nl) {
  PairSet s;
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const auto j = nl.partner[k];
      Vec<D> r = c.x[j] + nl.shift[nl.image[k]] - c.x[i];
      s.emplace(i, j, std::lround(r[0] * 1e6), std::lround(r[1] * 1e6), D == 3 ? std::lround(r[D - 1] * 1e6) : 0);
    }
  return s;
}

template <int D>
void check_matches(double dmin, double dmax, bool periodic) {
  for (unsigned seed : {1u, 2u, 3u}) {
    auto c = random_config<D>(D == 3 ? 900 : 400, dmin, dmax, periodic, seed);
    const double skin = 0.15;
    const auto expected = brute_force(c, skin);
    for (int threads : {1, 2}) {
      NeighbourList<D> nl;
      nl.configure(0.0, skin);
      nl.build(c.x, c.radius, c.box, threads);
      INFO("D = " << D << ", diameters [" << dmin << ", " << dmax << "], periodic " << periodic << ", seed " << seed
                  << ", threads " << threads);
      CHECK(from_list(c, nl) == expected);
      CHECK(expected.size() > 50);
    }
  }
}

}  // namespace

TEST_CASE("neighbour list equals the brute-force pair set", "[neighbours]") {
  for (bool periodic : {false, true}) {
    check_matches<3>(1.0, 1.0, periodic);
    check_matches<3>(0.1, 1.0, periodic);   // size ratio 10
    check_matches<2>(1.0, 1.0, periodic);
    check_matches<2>(0.1, 1.0, periodic);
  }
}

TEST_CASE("neighbour list keeps every contact while particles move less than skin/2", "[neighbours]") {
  auto c = random_config<3>(900, 0.1, 1.0, true, 9);
  const double skin = 0.2;
  NeighbourList<3> nl;
  nl.configure(0.0, skin);
  nl.build(c.x, c.radius, c.box, 1);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0, 1);
  for (auto& p : c.x) {
    Vec<3> d(g(rng), g(rng), g(rng));
    p += 0.499 * 0.5 * skin * d.normalized();   // just under skin/2: no rebuild needed
  }
  CHECK_FALSE(nl.stale(c.x));
  const auto touching = brute_force(c, 0.0);
  const auto listed = from_list(c, nl);
  for (const auto& t : touching) CHECK(listed.count(t) == 1);
}

TEST_CASE("per-pair values are carried across a rebuild", "[neighbours]") {
  auto c = random_config<3>(500, 0.5, 1.0, true, 5);
  NeighbourList<3> nl;
  nl.configure(0.0, 0.2);
  nl.build(c.x, c.radius, c.box, 1);
  std::vector<double> tag(nl.pair_count());
  std::map<std::pair<std::size_t, std::size_t>, double> by_pair;
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) tag[k] = by_pair[{i, nl.partner[k]}] = 1.0 + k;
  for (auto& p : c.x) p[0] += 0.3;   // move everything: some pairs leave, some arrive
  for (std::size_t i = 0; i < c.x.size(); i += 3) c.x[i][1] += 0.4;
  for (auto& p : c.x) p = c.box.wrap(p);
  nl.build(c.x, c.radius, c.box, 2);
  nl.carry(tag, -1.0);
  std::size_t kept = 0, fresh = 0;
  for (std::size_t i = 0; i < c.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      auto it = by_pair.find({i, nl.partner[k]});
      if (it != by_pair.end()) {
        CHECK(tag[k] == it->second);
        ++kept;
      } else {
        CHECK(tag[k] == -1.0);
        ++fresh;
      }
    }
  CHECK(kept > 100);
  CHECK(fresh > 10);
}
