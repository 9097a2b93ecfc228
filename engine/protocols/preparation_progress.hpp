// Progress of a long preparation, for a caller that shows it. Random insertion of many particles takes minutes
// (10^6 spheres at solid fraction 0.3: one to two) before the first step, with nothing else to see; the runner
// draws a status line from these reports, the FMUs pass none.
#pragma once
#include <cstddef>
#include <functional>
#include <string_view>

namespace grains {

// `task` names the work (a random insertion's pass), `done` of `total` items are through.
using PreparationProgress = std::function<void(std::string_view task, std::size_t done, std::size_t total)>;

}  // namespace grains
