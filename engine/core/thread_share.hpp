// How the particles are shared among threads: thread t of T owns a contiguous range, in thread order.
// Every per-particle loop (integration, force clearing, the pair loop's rows and its reduction) uses
// this one split, so a thread mostly touches the cache lines it wrote itself.
#pragma once
#include <cstddef>
#include <utility>

namespace grains {

inline std::pair<std::size_t, std::size_t> thread_share(std::size_t n, int t, int threads) {
  return {n * std::size_t(t) / std::size_t(threads), n * std::size_t(t + 1) / std::size_t(threads)};
}

}  // namespace grains
