#include "interactions/gravity_direct.hpp"
#include "interactions/gravity_avx512.hpp"
#include "interactions/gravity_lanes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>

#include <immintrin.h>

namespace grains::gravity_direct {

bool supported(Isa isa) {
  switch (isa) {
    case Isa::avx512: return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case Isa::avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    default: return true;
  }
}

const char* isa_name(Isa isa) { return isa == Isa::avx512 ? "avx512" : isa == Isa::avx2 ? "avx2" : "portable"; }

Isa fastest_isa() {
  static const Isa isa = [] {
    if (const char* want = std::getenv("GRAINS_GRAVITY_ISA"))
      for (Isa i : {Isa::portable, Isa::avx2, Isa::avx512})
        if (std::strcmp(want, isa_name(i)) == 0 && supported(i)) return i;
    return supported(Isa::avx512) ? Isa::avx512 : supported(Isa::avx2) ? Isa::avx2 : Isa::portable;
  }();
  return isa;
}

std::string environment_problem() {
  const char* want = std::getenv("GRAINS_GRAVITY_ISA");
  if (!want) return "";
  for (Isa i : {Isa::portable, Isa::avx2, Isa::avx512})
    if (std::strcmp(want, isa_name(i)) == 0)
      return supported(i) ? "" : "GRAINS_GRAVITY_ISA = \"" + std::string(want) +
                                     "\": this processor cannot run those kernels (unset it, or name a narrower set)";
  return "GRAINS_GRAVITY_ISA = \"" + std::string(want) +
         "\" is not a set of gravity kernels: allowed portable, avx2, avx512 (unset: the widest the processor runs)";
}

namespace {

// Where a tile adds acceleration terms: particle k's into x[k - first], y[k - first], z[k - first].
struct Sums {
  double *x, *y, *z;
  std::size_t first;
};

// ---------------------------------------------------------------------------------------------
// Portable kernels.
// ---------------------------------------------------------------------------------------------

// Pairs (i, j), i in block I, j in block J (j > i when I == J): a_i += m_j g_ij into `si`, a_j -= m_i g_ij
// into `sj`.
void tile_portable(const Columns& c, double eps2, std::size_t I, std::size_t J, Sums si, Sums sj) {
  const std::size_t B = c.block;
  const std::size_t i1 = std::min(I * B + B, c.n), j1 = std::min(J * B + B, c.n);
  for (std::size_t i = I * B; i < i1; ++i) {
    const double xi = c.x[i], yi = c.y[i], zi = c.z[i], mi = c.m[i];
    double sx = 0, sy = 0, sz = 0;
    for (std::size_t j = I == J ? i + 1 : J * B; j < j1; ++j) {
      const double dx = c.x[j] - xi, dy = c.y[j] - yi, dz = c.z[j] - zi;
      const double r2 = dx * dx + dy * dy + dz * dz + eps2;
      const double t = 1.0 / (r2 * std::sqrt(r2));
      const double wi = c.m[j] * t, wj = mi * t;
      sx += wi * dx, sy += wi * dy, sz += wi * dz;
      sj.x[j - sj.first] -= wj * dx, sj.y[j - sj.first] -= wj * dy, sj.z[j - sj.first] -= wj * dz;
    }
    si.x[i - si.first] += sx, si.y[i - si.first] += sy, si.z[i - si.first] += sz;
  }
}

// sum_{j > i} m_j / sqrt(d^2 + eps^2).
double potential_row_portable(const Columns& c, double eps2, std::size_t i) {
  const double xi = c.x[i], yi = c.y[i], zi = c.z[i];
  double s = 0;
  for (std::size_t j = i + 1; j < c.n; ++j) {
    const double dx = c.x[j] - xi, dy = c.y[j] - yi, dz = c.z[j] - zi;
    s += c.m[j] / std::sqrt(dx * dx + dy * dy + dz * dz + eps2);
  }
  return s;
}

// ---------------------------------------------------------------------------------------------
// Vector kernels (gravity_direct_tiles.inc), once per instruction set.
// AVX2 + FMA: four j at a time. The square root and division run on the divider while the FMA units do the
// rest; on the machine this was tuned on (AMD Zen 3) that beat an FP32 rsqrt estimate refined in FP64.
// AVX-512: eight j at a time, lanes kept as a bit mask; 1 / r2^{3/2} from a refined reciprocal square root
// (gravity_avx512.hpp: within a few units in the last place), not from the divider. The j side is walked in
// chunks of 512 particles: a chunk's coordinates, masses and sums (7 x 8 bytes each, 28 KB) stay in the
// first-level cache, which a whole block (up to n / 16 particles) outgrows from n ~ 10^4 on.
// ---------------------------------------------------------------------------------------------

namespace avx2 {
using V = lanes::Avx2F64;
constexpr std::size_t j_chunk = std::size_t(-1);   // the whole block
#define GRAINS_GRAVITY_KERNEL GRAINS_AVX2
#include "interactions/gravity_direct_tiles.inc"
#undef GRAINS_GRAVITY_KERNEL
}  // namespace avx2

namespace avx512 {
using V = lanes::Avx512F64;
constexpr std::size_t j_chunk = 512;   // a multiple of 8, so chunks start on a vector
#define GRAINS_GRAVITY_KERNEL GRAINS_AVX512
#include "interactions/gravity_direct_tiles.inc"
#undef GRAINS_GRAVITY_KERNEL
}  // namespace avx512

}  // namespace

void accelerations(Isa isa, const Columns& c, double eps2, int threads, std::vector<double>& ax, std::vector<double>& ay,
                   std::vector<double>& az) {
  // Task I takes the tiles (I, J >= I): block I's own sums (and the j side of the diagonal tile) go into
  // a{x,y,z} directly; the j side of tile (I, J > I) into its own slot of `spill`, added below in I order.
  // No task writes where another does, and a particle's terms are summed in an order set by n alone.
  const std::size_t S = c.block, blocks = c.x.size() / S;
  for (auto* a : {&ax, &ay, &az}) a->assign(c.x.size(), 0.0);
  auto slot = [&](std::size_t I, std::size_t J) { return 3 * S * (I * (2 * blocks - I - 1) / 2 + J - I - 1); };
  std::vector<double> spill(3 * S * blocks * (blocks - 1) / 2, 0.0);
  auto* tile = isa == Isa::avx512 ? avx512::tile : isa == Isa::avx2 ? avx2::tile : tile_portable;
  // Task I costs blocks - I - 1/2 tiles: handed out in that (decreasing) order, they balance the threads.
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
  for (std::size_t I = 0; I < blocks; ++I) {
    const Sums own{ax.data(), ay.data(), az.data(), 0};
    tile(c, eps2, I, I, own, own);
    for (std::size_t J = I + 1; J < blocks; ++J) {
      double* s = &spill[slot(I, J)];
      tile(c, eps2, I, J, own, Sums{s, s + S, s + 2 * S, J * S});
    }
  }
  // Serial: n (blocks - 1) / 2 additions per axis, and no second parallel region to start.
  for (std::size_t J = 1; J < blocks; ++J)
    for (std::size_t I = 0; I < J; ++I) {
      const double* s = &spill[slot(I, J)];
      for (std::size_t k = 0; k < S; ++k) ax[J * S + k] += s[k], ay[J * S + k] += s[S + k], az[J * S + k] += s[2 * S + k];
    }
  for (auto* a : {&ax, &ay, &az}) a->resize(c.n);
}

double potential(Isa isa, const Columns& c, double eps2, int threads) {
  std::vector<double> row(c.n, 0.0);
  auto* row_sum = isa == Isa::avx512 ? avx512::potential_row : isa == Isa::avx2 ? avx2::potential_row : potential_row_portable;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 16)
  for (std::size_t i = 0; i < c.n; ++i) row[i] = c.m[i] * row_sum(c, eps2, i);
  double energy = 0;
  for (double r : row) energy -= r;
  return energy;
}

}  // namespace grains::gravity_direct
