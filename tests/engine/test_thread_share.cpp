// How threads share particles and the rows of the neighbour list (core/thread_share.hpp): contiguous,
// in thread order, covering everything once; rows balanced by their entries, or by their cost.
#include <catch2/catch.hpp>

#include <random>

#include "core/thread_share.hpp"

using namespace grains;

TEST_CASE("thread shares: particles in equal contiguous ranges, rows by their entries", "[threads]") {
  for (int T : {1, 2, 3, 4}) {
    std::size_t next = 0;
    for (int t = 0; t < T; ++t) {
      const auto [b, e] = thread_share(1001, t, T);
      CHECK(b == next);
      CHECK(e - b >= 1001 / T);
      CHECK(e - b <= 1001 / T + 1);
      next = e;
    }
    CHECK(next == 1001);
  }
  // Rows of a list stored under the lower index: early rows are longer (here 40 down to 0 entries),
  // with random lengths on top.
  std::mt19937 rng(3);
  std::vector<std::uint32_t> start{0};
  const std::size_t rows = 1400;
  std::size_t longest = 0;
  for (std::size_t i = 0; i < rows; ++i) {
    const std::size_t length = (rows - i) * 40 / rows + rng() % 5;
    longest = std::max(longest, length);
    start.push_back(start.back() + std::uint32_t(length));
  }
  for (int T : {1, 2, 3}) {
    INFO(T << " threads");
    std::size_t next = 0;
    for (int t = 0; t < T; ++t) {
      const auto [b, e] = row_share(start, t, T);
      CHECK(b == next);
      const double entries = start[e] - start[b], even = double(start[rows]) / T;
      CHECK(std::abs(entries - even) <= double(longest));   // as even as whole rows allow
      next = e;
    }
    CHECK(next == rows);
  }
  // The equal-particle split would be far off: the first half of the rows holds about 3/4 of the entries.
  const auto [b, e] = thread_share(rows, 0, 2);
  CHECK(double(start[e] - start[b]) > 0.7 * start[rows]);
  CHECK(row_share(std::vector<std::uint32_t>{}, 0, 2) == std::pair<std::size_t, std::size_t>{0, 0});
}

TEST_CASE("thread shares: rows by their cost, a pair crossing to a later thread's rows counting twice", "[threads]") {
  // A ring of 1200 particles, each paired with its next 20, every pair stored under its lower index: a row
  // lists its next particles, and the first rows also those the ring wraps around to at the end (as pairs
  // across a periodic boundary do). Pairs near the end of a thread's rows, and the wrapped ones, cross.
  const std::size_t rows = 1200, reach = 20;
  std::vector<std::vector<std::uint32_t>> lists(rows);
  for (std::size_t i = 0; i < rows; ++i)
    for (std::size_t d = 1; d <= reach; ++d) {
      const std::size_t j = (i + d) % rows;
      lists[std::min(i, j)].push_back(std::uint32_t(std::max(i, j)));
    }
  std::vector<std::uint32_t> start{0}, partner;
  for (const auto& l : lists) {
    partner.insert(partner.end(), l.begin(), l.end());
    start.push_back(std::uint32_t(partner.size()));
  }
  for (int T : {1, 2, 3}) {
    INFO(T << " threads");
    const auto even = row_bounds(start, partner.data(), T, 0), weighted = row_bounds(start, partner.data(), T, 1);
    REQUIRE(even.size() == std::size_t(T) + 1);
    REQUIRE(weighted.size() == std::size_t(T) + 1);
    CHECK(even.front() == 0);
    CHECK(weighted.front() == 0);
    CHECK(even.back() == rows);
    CHECK(weighted.back() == rows);
    for (int t = 0; t < T; ++t) {
      CHECK(even[std::size_t(t)] == row_share(start, t, T).first);   // no extra cost: the even split
      CHECK(weighted[std::size_t(t)] <= weighted[std::size_t(t) + 1]);
    }
    // The cost of thread t's rows [b, e): its entries, and once more those whose partner is e or beyond.
    const auto cost = [&](std::size_t b, std::size_t e) {
      std::size_t c = 0;
      for (std::size_t i = b; i < e; ++i)
        for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) c += 1 + (partner[k] >= e ? 1 : 0);
      return c;
    };
    std::size_t lightest = SIZE_MAX, heaviest = 0, lightest_even = SIZE_MAX, heaviest_even = 0;
    for (int t = 0; t < T; ++t) {
      const std::size_t c = cost(weighted[std::size_t(t)], weighted[std::size_t(t) + 1]);
      const std::size_t ce = cost(even[std::size_t(t)], even[std::size_t(t) + 1]);
      lightest = std::min(lightest, c), heaviest = std::max(heaviest, c);
      lightest_even = std::min(lightest_even, ce), heaviest_even = std::max(heaviest_even, ce);
    }
    INFO("cost of the threads' rows: " << lightest << " .. " << heaviest << ", split evenly " << lightest_even << " .. "
                                        << heaviest_even);
    if (T == 1) {
      CHECK(heaviest == heaviest_even);
    } else {
      CHECK(heaviest - lightest <= 2 * 2 * reach);   // as even as whole rows allow (a row near a bound costs up to 2 reach)
      CHECK(heaviest - lightest < heaviest_even - lightest_even);
      CHECK(weighted[1] < even[1]);   // the first thread, which takes crossing pairs, takes fewer rows
    }
  }
}
