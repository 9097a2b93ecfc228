// Direct summation of softened gravity (physics.md section 7), without G:
//   a_i = sum_{j != i} m_j r_ij / (d^2 + eps^2)^{3/2},   W = -sum_{i<j} m_i m_j / sqrt(d^2 + eps^2).
// Forces use each pair once (a_i += m_j g_ij, a_j -= m_i g_ij). The particles are cut into at most 16
// blocks; a task takes one block against itself and all later blocks, writing the later blocks' terms into
// slots of its own, which are added at the end in a fixed order: the tasks run on any number of threads
// with no barrier between them, and results are bit-identical on 1 and 2 threads.
// Every term is computed in FP64 with a correctly rounded square root and division: g_ij = r_ij / (r2 sqrt(r2)),
// r2 = d^2 + eps^2 (the AVX-512 force kernel excepted: see gravity_direct.cpp). Three builds of the same loops,
// picked at run time so the binary stays portable x86-64: AVX-512 (eight pairs at a time), AVX2 + FMA (four)
// and plain scalar code. They agree to round-off, not bit for bit.
#pragma once
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "core/particles.hpp"

namespace grains::gravity_direct {

enum class Isa { portable, avx2, avx512 };

bool supported(Isa isa);      // the CPU (and OS) can run the kernels of `isa`
// The kernels the module uses: the best supported, unless the environment variable GRAINS_GRAVITY_ISA
// ("portable", "avx2" or "avx512") names another supported one (for tests and benchmarks). Read once.
Isa fastest_isa();
const char* isa_name(Isa isa);   // "portable", "avx2", "avx512"
// What is wrong with GRAINS_GRAVITY_ISA, naming its value and what is allowed ("" if nothing): a name it
// does not know, or kernels this processor cannot run. Simulations refuse to start on it.
std::string environment_problem();

// Positions and masses as separate contiguous arrays, padded to whole blocks with massless particles at the
// origin (the kernels mask them out); z = 0 in 2D, which only adds exact zeros.
struct Columns {
  static constexpr std::size_t width = 8;   // doubles per AVX-512 vector (two AVX2 vectors)
  std::size_t n = 0;
  // Particles per block, a function of n only: at most 16 blocks (the spill slots hold about 8 n
  // accelerations), at least 128 particles (the per-row overhead stays small).
  std::size_t block = 128;
  std::vector<double> x, y, z, m;

  template <int D>
  explicit Columns(const Particles<D>& P) : n(P.size()) {
    block = std::max<std::size_t>(128, ((n + 15) / 16 + width - 1) / width * width);
    const std::size_t padded = (n + block - 1) / block * block;
    for (auto* c : {&x, &y, &z, &m}) c->assign(padded, 0.0);
    for (std::size_t i = 0; i < n; ++i) {
      x[i] = P.position[i][0], y[i] = P.position[i][1], m[i] = P.mass[i];
      if constexpr (D == 3) z[i] = P.position[i][2];
    }
  }
};

// Accelerations (without G) of all particles into a{x,y,z} (resized to c.n).
void accelerations(Isa isa, const Columns& c, double eps2, int threads, std::vector<double>& ax, std::vector<double>& ay,
                   std::vector<double>& az);

// W / G = -sum_{i<j} m_i m_j / sqrt(d^2 + eps^2): rows summed in parallel, then in index order.
double potential(Isa isa, const Columns& c, double eps2, int threads);

}  // namespace grains::gravity_direct
