// The occupied cells of a sparse grid in one flat open-addressed table (linear probing, a power-of-two capacity at
// least twice the cells, each slot's key and id side by side), behind a bitmap of 16 bits per particle that says
// which hashes are taken: a thin cloud's 3^D neighbour cells are mostly empty, and a miss is then one bit read from a
// bitmap that stays in cache rather than a probe of the table. Each cell gets an id, 0, 1, ... in the order of first
// insertion; nothing is allocated per cell (a std::unordered_map of vectors, 27 lookups a particle, had cost ~6 s a
// record of the softened-core check at 10^6 grains). Users: the softened-core check (core/softened_core.cpp) and the
// size classes' pair search (neighbours/size_class_pairs.hpp).
#pragma once
#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/cell_hash.hpp"

namespace grains {

template <int D>
class CellTable {
 public:
  using Cell = std::array<std::int64_t, D>;
  static constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  // n: at most how many cells will be inserted (the particles, say).
  explicit CellTable(std::size_t n)
      : shift_(64 - std::bit_width(std::bit_ceil(std::max<std::size_t>(2 * n, 16)) - 1)), mask_((std::size_t(1) << (64 - shift_)) - 1),
        slot_(mask_ + 1), bits_mask_(std::bit_ceil(std::max<std::size_t>(16 * n, 64)) - 1), bits_((bits_mask_ + 1) / 64) {}
  // The cell's id, a new one (the count so far) if it is not yet in the table.
  std::uint32_t insert(const Cell& c) {
    const std::size_t h = CellHash<D>{}(c);
    bits_[(h & bits_mask_) / 64] |= std::uint64_t(1) << (h % 64);
    for (std::size_t s = slot_of(h);; s = (s + 1) & mask_) {
      if (slot_[s].id == none) return slot_[s] = {c, size_}, size_++;
      if (same(slot_[s].key, c)) return slot_[s].id;
    }
  }
  // The cell's id, `none` if it holds nothing.
  std::uint32_t find(const Cell& c) const {
    const std::size_t h = CellHash<D>{}(c);
    if (!(bits_[(h & bits_mask_) / 64] >> (h % 64) & 1)) return none;
    for (std::size_t s = slot_of(h);; s = (s + 1) & mask_) {
      if (slot_[s].id == none) return none;
      if (same(slot_[s].key, c)) return slot_[s].id;
    }
  }
  std::uint32_t size() const { return size_; }

 private:
  // The slot from the hash's high bits, remixed (the bitmap takes its low bits): neighbouring cells' hashes share
  // structure that clustered the linear probes when the low bits picked the slot.
  std::size_t slot_of(std::size_t h) const { return std::size_t(std::uint64_t(h) * 0x9E3779B97F4A7C15ull >> shift_); }
  // Written out: std::array's == was a call to memcmp, a fifth of a compact aggregate's search.
  static bool same(const Cell& a, const Cell& b) {
    bool equal = true;
    for (int k = 0; k < D; ++k) equal &= a[k] == b[k];
    return equal;
  }
  struct Slot {
    Cell key{};
    std::uint32_t id = none;
  };
  int shift_;
  std::size_t mask_;
  std::vector<Slot> slot_;
  std::size_t bits_mask_;
  std::vector<std::uint64_t> bits_;
  std::uint32_t size_ = 0;
};

}  // namespace grains
