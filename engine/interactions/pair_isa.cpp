// Which build of the pair loop's vector pieces runs (pair_filter.hpp: isa, cap_isa).
#include <atomic>
#include <cstdlib>
#include <cstring>

#include "interactions/pair_filter.hpp"

namespace grains::pair_filter {
namespace {

// The widest build the processor runs, capped by GRAINS_PAIR_ISA (read once). POPCNT: the vector builds'
// bit counts (every AVX2 processor has it).
Isa available() {
  static const Isa widest = [] {
    Isa best = Isa::portable;
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt")) best = Isa::avx2;
    if (best == Isa::avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq"))
      best = Isa::avx512;
    const char* want = std::getenv("GRAINS_PAIR_ISA");
    if (want && std::strcmp(want, "portable") == 0) return Isa::portable;
    if (want && std::strcmp(want, "avx2") == 0 && best == Isa::avx512) return Isa::avx2;
    return best;
  }();
  return widest;
}

std::atomic<Isa> cap{Isa::avx512};

}  // namespace

Isa isa() {
  const Isa widest = available(), limit = cap.load(std::memory_order_relaxed);
  return limit < widest ? limit : widest;
}

void cap_isa(Isa widest) { cap.store(widest, std::memory_order_relaxed); }

const char* isa_name(Isa isa) { return isa == Isa::avx512 ? "avx512" : isa == Isa::avx2 ? "avx2" : "portable"; }

}  // namespace grains::pair_filter
