// AVX-512 build of the steady cohesive contacts (cohesive_contacts.hpp): cohesive_contacts_kernel.hpp at
// eight lanes. Compiled for AVX-512 whatever the build flags and without FMA contraction
// (engine/CMakeLists.txt).
#include <atomic>

#include "interactions/pair_avx512.hpp"

#define GRAINS_PAIR_KERNEL GRAINS_AVX512_PAIRS
#include "interactions/cohesive_contacts_kernel.hpp"

namespace grains::cohesive_contacts {
namespace {

std::atomic<long> dense_evaluations_{0};

}  // namespace

void note_dense_evaluation() { dense_evaluations_.fetch_add(1, std::memory_order_relaxed); }
long dense_evaluations() { return dense_evaluations_.load(); }

// The attraction's tail and the shell's quiet pairs completed here too: 4.5 % less processor time on the
// bench disks.
long evaluate_avx512(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                     std::size_t n, const Output& out) {
  return Kernel<pair_avx512::Width8, true>::evaluate(in, rows, pairs, images, n, out);
}

}  // namespace grains::cohesive_contacts
