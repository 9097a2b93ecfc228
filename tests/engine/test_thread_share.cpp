// How threads share particles and the rows of the neighbour list (core/thread_share.hpp): contiguous,
// in thread order, covering everything once; rows balanced by their entries.
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
