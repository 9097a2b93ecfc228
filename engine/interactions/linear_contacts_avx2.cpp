// AVX2 build of the steady contacts of spheres (linear_contacts.hpp), for processors without AVX-512:
// linear_contacts_kernel.hpp at four lanes, each batch filling half of a Results8. Compiled for AVX2
// whatever the build flags and without FMA contraction (engine/CMakeLists.txt).
#include "interactions/pair_avx2.hpp"

#define GRAINS_PAIR_KERNEL GRAINS_AVX2_PAIRS
#include "interactions/linear_contacts_kernel.hpp"

namespace grains::linear_contacts {

long evaluate_avx2(const Input& in, const std::uint32_t* rows, const std::uint32_t* pairs, const std::uint8_t* images,
                   std::size_t n, const Output& out) {
  return Kernel<pair_avx2::Width4>::evaluate(in, rows, pairs, images, n, out);
}

}  // namespace grains::linear_contacts
