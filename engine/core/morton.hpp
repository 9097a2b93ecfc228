// Morton (Z-order) keys: each coordinate quantised to key_bits<D> bits and the bits interleaved, axis a
// at bit a of every D-bit digit (the top digit names the octant or quadrant of the whole cube). Sorting
// by key puts points close in space close in the order: the gravity tree builds its cells from it, and
// random initial layouts number their particles along it.
#pragma once
#include <array>
#include <cstddef>
#include <utility>
#include <vector>

namespace grains::morton {

// Bits of a key per axis: 3 x 21 or 2 x 31 bits fit one 64-bit key.
template <int D>
constexpr int key_bits = D == 3 ? 21 : 31;

// The low key_bits<D> bits of c spread out, bit b to bit D b: each shift-and-mask step cuts the bits into
// chunks half as wide and moves them apart ("magic numbers"), five steps instead of a loop over the bits.
template <int D>
inline unsigned long long spread_bits(unsigned long long c) {
  if constexpr (D == 3) {
    c &= 0x1fffffULL;
    c = (c | c << 32) & 0x1f00000000ffffULL;
    c = (c | c << 16) & 0x1f0000ff0000ffULL;
    c = (c | c << 8) & 0x100f00f00f00f00fULL;
    c = (c | c << 4) & 0x10c30c30c30c30c3ULL;
    c = (c | c << 2) & 0x1249249249249249ULL;
  } else {
    c &= 0xffffffffULL;
    c = (c | c << 16) & 0x0000ffff0000ffffULL;
    c = (c | c << 8) & 0x00ff00ff00ff00ffULL;
    c = (c | c << 4) & 0x0f0f0f0f0f0f0f0fULL;
    c = (c | c << 2) & 0x3333333333333333ULL;
    c = (c | c << 1) & 0x5555555555555555ULL;
  }
  return c;
}

// The key of quantised coordinates q[a] < 2^key_bits<D>.
template <int D>
inline unsigned long long key(const std::array<unsigned long long, D>& q) {
  unsigned long long k = 0;
  for (int a = 0; a < D; ++a) k |= spread_bits<D>(q[a]) << a;
  return k;
}

// Sorts keys (carrying index along) by key, eight bits a pass from the lowest: a stable sort, so equal keys
// keep the index order (the order std::sort gives the (key, index) pairs), in a fraction of its time. The
// eight passes' digit counts are taken in one read of the keys.
inline void radix_sort(std::vector<unsigned long long>& keys, std::vector<int>& index) {
  const std::size_t n = keys.size();
  if (n == 0) return;
  std::array<std::array<std::size_t, 256>, 8> start{};
  for (const unsigned long long key : keys)
    for (int pass = 0; pass < 8; ++pass) ++start[pass][(key >> (8 * pass)) & 0xff];
  std::vector<unsigned long long> keys2(n);
  std::vector<int> index2(n);
  for (int pass = 0; pass < 8; ++pass) {
    const int shift = 8 * pass;
    auto& at = start[pass];
    if (at[(keys[0] >> shift) & 0xff] == n) continue;   // one digit value throughout: nothing moves
    std::size_t sum = 0;
    for (auto& s : at) sum += std::exchange(s, sum);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t to = at[(keys[k] >> shift) & 0xff]++;
      keys2[to] = keys[k], index2[to] = index[k];
    }
    keys.swap(keys2), index.swap(index2);
  }
}
}  // namespace grains::morton
