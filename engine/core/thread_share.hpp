// How the particles are shared among threads: thread t of T owns a contiguous range, in thread order.
// Every per-particle loop (integration, force clearing, the pair loop's reduction) uses this one split,
// so a thread mostly touches the cache lines it wrote itself; the pair loop's rows follow it closely
// (row_share).
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
    if (u <= 0) return 0;
    if (u >= threads) return rows;
    const std::uint64_t target = std::uint64_t(start[rows]) * std::uint64_t(u) / std::uint64_t(threads);
    return std::size_t(std::lower_bound(start.begin(), start.begin() + rows, target) - start.begin());
  };
  return {row_at(t), row_at(t + 1)};
}

}  // namespace grains
