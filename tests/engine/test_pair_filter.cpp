// The pair loop's first pass (interactions/pair_filter.hpp): the AVX-512 (positions gathered and loaded) and AVX2 builds (each where the
// processor has it) select exactly the entries the portable build selects, in the same order, with the same rows, on random polydisperse packings (2D
// and 3D, open and periodic, with and without an attraction range, particles moved since the list was
// built, runs of rows of every length) and on lattices whose neighbours sit exactly at reach, where the
// strict comparison decides (a single ulp of radius flips every pair). The portable build selects exactly
// the pairs closer than R_i + R_j + tail.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <vector>

#include "interactions/pair_filter.hpp"
#include "neighbours/neighbour_list.hpp"
#include "random_packing.hpp"

using namespace grains;

namespace {

bool has_avx512() { return pair_filter::supported(pair_filter::Isa::avx512); }
bool has_avx2() { return pair_filter::supported(pair_filter::Isa::avx2); }

template <int D>
pair_filter::Geometry<D> geometry(const Packing<D>& p, double tail) {
  const auto& nl = p.list;
  return {p.x.data(), p.radius.data(), nl.partner.data(), nl.owner.data(), nl.image.data(), nl.shift.data(), tail};
}

struct Selection {
  std::size_t n = 0;
  std::vector<std::uint32_t> rows, pairs;
  std::vector<std::uint8_t> images;
};

// Every build over the list in runs of `block` rows; returns the portable selection after comparing.
template <int D>
Selection compare_builds(const Packing<D>& p, double tail, std::size_t block) {
  const auto& nl = p.list;
  const auto g = geometry(p, tail);
  const std::size_t N = p.x.size();
  Selection all;
  for (std::size_t b = 0; b < N; b += block) {
    const std::size_t e = std::min(N, b + block);
    const std::size_t room = nl.start[e] - nl.start[b] + pair_filter::slack;
    // One selection of rows [b, e): its count and arrays.
    struct Run {
      std::size_t n = 0;
      std::vector<std::uint32_t> rows, pairs;
      std::vector<std::uint8_t> images;
    };
    const auto run = [&](const pair_filter::Geometry<D>& geom, auto select) {
      Run r{0, std::vector<std::uint32_t>(room, 0xFFFFFFFFu), std::vector<std::uint32_t>(room, 0xFFFFFFFFu),
            std::vector<std::uint8_t>(room, 0xFF)};
      r.n = select(geom, nl.start[b], nl.start[e], r.rows.data(), r.pairs.data(), r.images.data());
      return r;
    };
    // The portable build with the vector builds' signature (it takes the rows, they the entries).
    const auto gather_portable = [&](const pair_filter::Geometry<D>& geom, std::uint32_t, std::uint32_t, std::uint32_t* rows_out,
                                     std::uint32_t* pairs_out, std::uint8_t* images_out) {
      return pair_filter::gather_portable<D>(geom, nl.start.data(), b, e, rows_out, pairs_out, images_out);
    };
    // Each vector build against the portable one, over the list's entries and over a selection of them
    // (the shell's case: entry m stands for list entry `entry[m]`, which every build writes in place of m).
    std::vector<std::uint32_t> entry(nl.pair_count());
    for (std::size_t m = 0; m < entry.size(); ++m) entry[m] = std::uint32_t(7 * m + 3);
    pair_filter::Geometry<D> selection = g;
    selection.entry = entry.data();
    const Run portable = run(g, gather_portable);
    const Run portable_selection = run(selection, gather_portable);
    REQUIRE(portable_selection.n == portable.n);
    for (std::size_t q = 0; q < portable.n; ++q) CHECK(portable_selection.pairs[q] == 7 * portable.pairs[q] + 3);
    const auto compare = [&](const char* build, auto select) {
      for (const bool over_selection : {false, true}) {
        const Run& want = over_selection ? portable_selection : portable;
        const Run got = run(over_selection ? selection : g, select);
        const std::size_t n = want.n;
        INFO(build << (over_selection ? " over a selection" : "") << ", rows " << b << " to " << e);
        REQUIRE(got.n == n);
        CHECK(std::equal(want.pairs.begin(), want.pairs.begin() + n, got.pairs.begin()));
        CHECK(std::equal(want.rows.begin(), want.rows.begin() + n, got.rows.begin()));
        CHECK(std::equal(want.images.begin(), want.images.begin() + n, got.images.begin()));
      }
    };
    if (has_avx512()) {   // its positions gathered, and read by loads (pair_filter::vector_loads)
      const bool loads_before = pair_filter::vector_loads();
      pair_filter::set_vector_loads(false);
      compare("AVX-512", pair_filter::gather_avx512<D>);
      pair_filter::set_vector_loads(true);
      compare("AVX-512 (positions by loads)", pair_filter::gather_avx512<D>);
      pair_filter::set_vector_loads(loads_before);
    }
    if (has_avx2()) compare("AVX2", pair_filter::gather_avx2<D>);
    const std::size_t n = portable.n;
    const auto& rows = portable.rows;
    const auto& pairs = portable.pairs;
    const auto& images = portable.images;
    all.rows.insert(all.rows.end(), rows.begin(), rows.begin() + n);
    all.pairs.insert(all.pairs.end(), pairs.begin(), pairs.begin() + n);
    all.images.insert(all.images.end(), images.begin(), images.begin() + n);
    all.n += n;
  }
  return all;
}

// The portable selection is exactly the entries within reach (checked pair by pair, in list order).
template <int D>
void check_definition(const Packing<D>& p, double tail, const Selection& s) {
  const auto& nl = p.list;
  std::size_t q = 0;
  for (std::size_t i = 0; i < p.x.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      REQUIRE(nl.owner[k] == i);
      const std::uint32_t j = nl.partner[k];
      const double reach = p.radius[i] + p.radius[j] + tail;
      const bool in = (p.x[j] + nl.shift[nl.image[k]] - p.x[i]).squaredNorm() < reach * reach;
      if (in) {
        REQUIRE(q < s.n);
        CHECK(s.pairs[q] == k);
        CHECK(s.rows[q] == i);
        CHECK(s.images[q] == nl.image[k]);
        ++q;
      }
    }
  CHECK(q == s.n);
}

template <int D>
void random_cases() {
  if (!has_avx512()) WARN("this processor has no AVX-512: that build of the filter is not checked here");
  if (!has_avx2()) WARN("this processor has no AVX2: that build of the filter is not checked here");
  for (unsigned seed : {1u, 2u, 3u})
    for (bool periodic : {false, true})
      for (double tail : {0.0, 1e-3, 0.05}) {
        const auto p = random_packing<D>(periodic, tail, seed, 0.45 * 0.2);   // moved up to 0.45 skin
        INFO("D = " << D << ", seed " << seed << ", periodic " << periodic << ", tail " << tail);
        for (std::size_t block : {1, 7, 256, 100000}) {
          const Selection s = compare_builds(p, tail, block);
          CHECK(s.n > 300);                            // many interacting pairs ...
          CHECK(s.n < 0.9 * p.list.pair_count() - 100);   // ... and many listed ones that are not
          check_definition(p, tail, s);
        }
      }
}

// Unit spacing on a periodic lattice (k^D sites), radius r: lattice neighbours are exactly at d^2 = 1.
template <int D>
Packing<D> lattice(double r) {
  Packing<D> p;
  const int k = 6;
  for (int a = 0; a < D; ++a) p.box.length[a] = k, p.box.periodic[a] = true;
  for (int s = 0; s < (D == 3 ? k * k * k : k * k); ++s) {
    Vec<D> x;
    for (int a = 0, t = s; a < D; ++a, t /= k) x[a] = 0.5 + t % k;
    p.x.push_back(x);
    p.radius.push_back(r);
  }
  p.list.configure(0.0, 0.1);
  p.list.build(p.x, p.radius, p.box, 1);
  return p;
}

}  // namespace

TEST_CASE("pair filter: the vector and portable builds select the same pairs (2D)", "[pair-filter]") { random_cases<2>(); }

TEST_CASE("pair filter: the vector and portable builds select the same pairs (3D)", "[pair-filter]") { random_cases<3>(); }

TEST_CASE("pair filter: pairs exactly at reach are left out by every build, one ulp closer taken by every one", "[pair-filter]") {
  const auto at = lattice<3>(0.5);
  CHECK(compare_builds(at, 0.0, 64).n == 0);   // d^2 = 1 = (0.5 + 0.5)^2: not closer
  const auto closer = lattice<3>(std::nextafter(0.5, 1.0));
  CHECK(compare_builds(closer, 0.0, 64).n == 3 * 216);   // every lattice bond, across the periodic faces too
  const auto at2 = lattice<2>(0.5);
  CHECK(compare_builds(at2, 0.0, 5).n == 0);
  const auto closer2 = lattice<2>(std::nextafter(0.5, 1.0));
  CHECK(compare_builds(closer2, 0.0, 5).n == 2 * 36);
}
