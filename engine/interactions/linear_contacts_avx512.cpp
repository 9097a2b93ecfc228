// AVX-512 build of the steady contacts of spheres (linear_contacts.hpp): linear_contacts_kernel.hpp at
// eight lanes. Compiled for AVX-512 whatever the build flags and without FMA contraction
// (engine/CMakeLists.txt).
#include "interactions/pair_avx512.hpp"

#define GRAINS_PAIR_KERNEL GRAINS_AVX512_PAIRS
#include "interactions/linear_contacts_kernel.hpp"

namespace grains::linear_contacts {

long evaluate_avx512(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                     std::size_t n, const Output& out) {
  return Kernel<pair_avx512::Width8>::evaluate(in, rows, pairs, images, n, out);
}

}  // namespace grains::linear_contacts
