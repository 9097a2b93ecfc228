// AVX2 build of the steady cohesive contacts (cohesive_contacts.hpp), for processors without AVX-512:
// cohesive_contacts_kernel.hpp at four lanes, each batch filling half of a Results8. Compiled for AVX2
// whatever the build flags and without FMA contraction (engine/CMakeLists.txt).
#include "interactions/pair_avx2.hpp"

#define GRAINS_PAIR_KERNEL GRAINS_AVX2_PAIRS
#include "interactions/cohesive_contacts_kernel.hpp"

namespace grains::cohesive_contacts {

// The attraction's tail and the shell's quiet pairs are left to the pair loop (completing them was
// measured with the AVX-512 build only).
long evaluate_avx2(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                   std::size_t n, const Output& out) {
  return Kernel<pair_avx2::Width4, false>::evaluate(in, rows, pairs, images, n, out);
}

}  // namespace grains::cohesive_contacts
