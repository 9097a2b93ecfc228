// A particle's periodic image (H5MD's `image`): per axis, the whole cell lengths its wrapping has taken off
// its position, so that its unwrapped position is the wrapped one plus image * length. The cell's length
// changing (the barostat's affine flow) changes no image: the unwrapped position follows the flow with it.
#pragma once
#include <array>
#include <cstdint>

namespace grains {

// 64 bits: no count a run can reach overflows them, and the file stores them as they are.
template <int D>
using Image = std::array<std::int64_t, D>;

}  // namespace grains
