// Which build of the pair loop's vector pieces runs (pair_filter.hpp: isa, cap_isa).
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <string>

#include "interactions/pair_filter.hpp"

namespace grains::pair_filter {
// What each vector build needs of the processor. POPCNT: the vector builds' bit counts (every AVX2
// processor has it).
bool supported(Isa isa) {
  switch (isa) {
    case Isa::avx512:
      return supported(Isa::avx2) && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
    case Isa::avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt");
    default: return true;
  }
}

namespace {

// The widest build the processor runs, capped by GRAINS_PAIR_ISA (read once).
Isa available() {
  static const Isa widest = [] {
    const Isa best = supported(Isa::avx512) ? Isa::avx512 : supported(Isa::avx2) ? Isa::avx2 : Isa::portable;
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

namespace {

std::atomic<int> loads_set{-1};   // set_vector_loads: 0, 1; -1 not set

}  // namespace

bool vector_loads() {
  static const bool by_default = [] {
    const char* want = std::getenv("GRAINS_PAIR_LOADS");
    if (want && std::strcmp(want, "gather") == 0) return false;
    if (want && std::strcmp(want, "load") == 0) return true;
    return bool(__builtin_cpu_is("amd"));
  }();
  const int set = loads_set.load(std::memory_order_relaxed);
  return set < 0 ? by_default : set == 1;
}

void set_vector_loads(bool loads) { loads_set.store(loads ? 1 : 0, std::memory_order_relaxed); }

const char* isa_name(Isa isa) { return isa == Isa::avx512 ? "avx512" : isa == Isa::avx2 ? "avx2" : "portable"; }

namespace {

std::string isa_problem() {
  const char* want = std::getenv("GRAINS_PAIR_ISA");
  if (!want) return "";
  for (Isa i : {Isa::portable, Isa::avx2, Isa::avx512})
    if (std::strcmp(want, isa_name(i)) == 0)
      return supported(i) ? "" : "GRAINS_PAIR_ISA = \"" + std::string(want) +
                                     "\": this processor cannot run that build (unset it, or name a narrower one)";
  return "GRAINS_PAIR_ISA = \"" + std::string(want) +
         "\" is not a build of the pair loop: allowed portable, avx2, avx512 (unset: the widest the processor runs)";
}

std::string loads_problem() {
  const char* want = std::getenv("GRAINS_PAIR_LOADS");
  if (!want || std::strcmp(want, "gather") == 0 || std::strcmp(want, "load") == 0) return "";
  return "GRAINS_PAIR_LOADS = \"" + std::string(want) +
         "\" is not a way of reading vectors: allowed gather, load (unset: load on AMD processors, gather elsewhere)";
}

}  // namespace

std::string environment_problem() {
  std::string problem = isa_problem();
  return problem.empty() ? loads_problem() : problem;
}

}  // namespace grains::pair_filter
