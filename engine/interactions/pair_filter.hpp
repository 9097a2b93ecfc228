// The first pass of the pair loop: of a run of neighbour-list entries, which pairs interact (their
// centres closer than R_i + R_j + tail_reach). Most listed pairs do not, so this pass is the hot one
// in dilute scenes. Three builds of the same test, picked at run time so the binary stays portable
// x86-64: plain scalar code, AVX-512 (eight entries at a time, the result compressed into place) and AVX2
// (four at a time, compressed by a permutation). All form r = (x_j + shift) - x_i, d^2 = (r_x^2 + r_y^2) + r_z^2 and (R_i + R_j + tail)^2 with the same
// operations in the same order (the vector files are compiled without FMA contraction), so they select
// exactly the same entries, in list order: the forces are bit-identical whichever runs.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/vec.hpp"

namespace grains::pair_filter {

template <int D>
struct Geometry {
  const Vec<D>* position;
  const double* radius;
  const std::uint32_t* partner;   // the list's j of each entry
  const std::uint32_t* owner;     // the list's row (i) of each entry
  const std::uint8_t* image;      // index into shift
  const Vec<D>* shift;            // 3^D periodic image shifts, indexed by sum (k_a + 1) 3^a
  double tail_reach;              // gap up to which a pair interacts (0: touching only)
  // Null: the entries are the Verlet list's own, and entry m is list entry m. Else the arrays above
  // hold a selection of its entries (neighbours/shell_list.hpp), entry m being list entry `entry[m]`:
  // the entries written to pairs[] are always the list's.
  const std::uint32_t* entry = nullptr;
};

// Writes the interacting entries k of rows [row_begin, row_end) (entries start[row_begin] ..
// start[row_end] of g's arrays) to pairs[], their rows to rows[] and their images to images[], in list
// order; returns how many. The arrays must hold the run's entries plus `slack` (the vector builds
// store whole vectors).
inline constexpr std::size_t slack = 8;

template <int D>
std::size_t gather_portable(const Geometry<D>& g, const std::uint32_t* start, std::size_t row_begin, std::size_t row_end,
                            std::uint32_t* rows, std::uint32_t* pairs, std::uint8_t* images) {
  std::size_t n = 0;
  for (std::size_t i = row_begin; i < row_end; ++i) {
    const Vec<D> xi = g.position[i];
    const double Ri = g.radius[i];
    const std::uint32_t end = start[i + 1];
    for (std::uint32_t m = start[i]; m < end; ++m) {   // without a branch: store, then count if it interacts
      const Vec<D> r = g.position[g.partner[m]] + g.shift[g.image[m]] - xi;
      const double reach = Ri + g.radius[g.partner[m]] + g.tail_reach;
      rows[n] = std::uint32_t(i), pairs[n] = g.entry ? g.entry[m] : m, images[n] = g.image[m];
      n += r.squaredNorm() < reach * reach;
    }
  }
  return n;
}

// The AVX-512 build (pair_filter_avx512.cpp) over entries [k_begin, k_end) of g's arrays; only where isa() is avx512.
template <int D>
std::size_t gather_avx512(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                          std::uint32_t* pairs, std::uint8_t* images);
// The AVX2 build (pair_filter_avx2.cpp), likewise; only where isa() is avx2.
template <int D>
std::size_t gather_avx2(const Geometry<D>& g, std::uint32_t k_begin, std::uint32_t k_end, std::uint32_t* rows,
                        std::uint32_t* pairs, std::uint8_t* images);

// Which build of the pair loop's vector pieces runs (this filter, the batched contact kernels, the
// neighbour build's candidate test): the widest the processor has, AVX-512 (F, VL, BW, DQ) or AVX2, else
// the portable code. The environment variable GRAINS_PAIR_ISA (read once) caps it: "portable" or "avx2"
// ("avx512": no cap; anything else stops a simulation, environment_problem); so does a test, with cap_isa.
// Every build gives the same results, bit for bit.
enum class Isa { portable, avx2, avx512 };
Isa isa();
void cap_isa(Isa widest);
bool supported(Isa isa);   // the processor can run that build (whatever the caps)
const char* isa_name(Isa isa);   // "portable", "avx2", "avx512": for run summaries
// What is wrong with GRAINS_PAIR_ISA or GRAINS_PAIR_LOADS, naming the variable, its value and what is
// allowed ("" if nothing): a name it does not know, or a build this processor cannot run. Simulations refuse
// to start on it (a benchmark would otherwise measure another build than the one asked for).
std::string environment_problem();
inline bool avx512() { return isa() == Isa::avx512; }

// Whether the AVX-512 builds read a full vector's 2D vectors by eight 16-byte loads and two shuffles
// (pair_avx512.hpp's load_2d) rather than by gathers: the dense cohesive kernel its velocities (its positions
// always), this filter its positions (x and y; z still gathered in 3D). The same values either way, so the
// same results. On AMD processors by default: on Zen 4 eight such loads took 2.60 ns where the two gathers took
// 5.75 ns, and the bench disks ran 1.10x faster, the gas 1.04-1.08x; on the Xeon the loads' shuffles compete
// with the kernel's own for one port and measured slower in the kernel. The environment variable
// GRAINS_PAIR_LOADS ("gather" or "load", read once) or a test (set_vector_loads) overrides it.
bool vector_loads();
void set_vector_loads(bool loads);

template <int D>
std::size_t gather(const Geometry<D>& g, const std::uint32_t* start, std::size_t row_begin, std::size_t row_end,
                   std::uint32_t* rows, std::uint32_t* pairs, std::uint8_t* images) {
  switch (isa()) {
    case Isa::avx512: return gather_avx512<D>(g, start[row_begin], start[row_end], rows, pairs, images);
    case Isa::avx2: return gather_avx2<D>(g, start[row_begin], start[row_end], rows, pairs, images);
    default: return gather_portable<D>(g, start, row_begin, row_end, rows, pairs, images);
  }
}

}  // namespace grains::pair_filter
