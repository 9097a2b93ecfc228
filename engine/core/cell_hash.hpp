// A hash of an integer grid cell, for sparse grids: the particles of an open box may spread over any range,
// so the cells are not held in an array. The flat open-addressed CellTable (core/cell_table.hpp) keys by it, for
// the softened-core check (core/softened_core.cpp) and the size classes' pair search of the starting-overlap check
// and the cluster analysis (neighbours/size_class_pairs.hpp); the neighbour list, when a dense grid would need too
// many cells, counting-sorts its particles into buckets (the hash's low bits), see neighbours/neighbour_list.cpp.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>

namespace grains {

template <int D>
struct CellHash {
  std::size_t operator()(const std::array<std::int64_t, D>& c) const {
    std::uint64_t h = 0x9E3779B97F4A7C15ull;
    for (int a = 0; a < D; ++a) h = (h ^ std::uint64_t(c[a])) * 0xBF58476D1CE4E5B9ull, h ^= h >> 31;
    return std::size_t(h);
  }
};

}  // namespace grains
