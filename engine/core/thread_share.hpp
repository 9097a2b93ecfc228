// How the particles are shared among threads: thread t of T owns a contiguous range, in thread order.
// Every per-particle loop (integration, force clearing, the kinetic stress, the pair loop's reduction) uses
// this one split, so a thread mostly touches the cache lines it wrote itself; the pair loop's rows follow it
// closely (row_share, and row_bounds, which the pair loop uses).
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace grains {

inline std::pair<std::size_t, std::size_t> thread_share(std::size_t n, int t, int threads) {
  return {n * std::size_t(t) / std::size_t(threads), n * std::size_t(t + 1) / std::size_t(threads)};
}

// The rows of a CSR list (row i holds entries start[i] .. start[i+1]) shared so that each thread gets
// about as many entries: a neighbour pair is stored under its lower index, so equal particle counts
// would give the first threads more pairs (54 % against 46 % for two threads on an aggregated sample).
// Contiguous and in thread order, like thread_share.
inline std::pair<std::size_t, std::size_t> row_share(const std::vector<std::uint32_t>& start, int t, int threads) {
  const std::size_t rows = start.empty() ? 0 : start.size() - 1;
  const auto row_at = [&](int u) -> std::size_t {
    if (u <= 0 || rows == 0) return 0;   // an empty list has no start[rows] to read
    if (u >= threads) return rows;
    const std::uint64_t target = std::uint64_t(start[rows]) * std::uint64_t(u) / std::uint64_t(threads);
    return std::size_t(std::lower_bound(start.begin(), start.begin() + rows, target) - start.begin());
  };
  return {row_at(t), row_at(t + 1)};
}

// The rows shared by their cost, as the T + 1 bounds of the threads' ranges (thread t takes rows
// [bounds[t], bounds[t+1])). An entry costs one, and `cross` more where its partner lies beyond its thread's
// rows: a pair is stored under its lower index, so the earlier threads take every pair that crosses a
// boundary between threads, and such a pair's partner has its force added through the thread's own array,
// merged after the loop, and its data written by another core. Which pairs cross depends on the split:
// starting from row_share's, each round splits the cumulative cost measured against the last round's
// bounds (three rounds: the bounds then move by a row or two at most).
inline std::vector<std::size_t> row_bounds(const std::vector<std::uint32_t>& start, const std::uint32_t* partner, int threads,
                                           std::uint32_t cross) {
  const std::size_t rows = start.empty() ? 0 : start.size() - 1;
  std::vector<std::size_t> bounds(std::size_t(threads) + 1, rows);
  for (int t = 0; t < threads; ++t) bounds[std::size_t(t)] = row_share(start, t, threads).first;
  std::vector<std::uint64_t> cost(rows + 1, 0);   // cumulative: cost[i] is the cost of rows [0, i)
  for (int round = 0; round < (cross ? 3 : 0); ++round) {
    for (int t = 0; t < threads; ++t) {
      const std::size_t b = bounds[std::size_t(t)], e = bounds[std::size_t(t) + 1];
      for (std::size_t i = b; i < e; ++i) {
        std::uint64_t c = start[i + 1] - start[i];
        for (std::uint32_t k = start[i]; k < start[i + 1]; ++k) c += partner[k] >= e ? cross : 0;
        cost[i + 1] = cost[i] + c;
      }
    }
    for (int t = 1; t < threads; ++t) {
      const std::uint64_t target = cost[rows] * std::uint64_t(t) / std::uint64_t(threads);
      bounds[std::size_t(t)] = std::size_t(std::lower_bound(cost.begin(), cost.end() - 1, target) - cost.begin());
    }
  }
  return bounds;
}

}  // namespace grains
