// The inner loop of the neighbour-list build: of a run of grid slots (candidates, in cell order), which
// lie within reach of particle p. Two builds of the same test, picked at run time so the binary stays
// portable x86-64: plain scalar code, and AVX-512 (eight slots at a time, the finds compressed into place).
// Both form the separations and d^2 with the same operations in the same order (the AVX-512 file is
// compiled without FMA contraction), so they find the same pairs in the same order: the lists are
// identical whichever runs.
#pragma once
#include <cstddef>
#include <cstdint>

namespace grains::candidate_test {

// A particle's view of one grid: the grid's slots in structure-of-arrays form and the particle.
template <int D>
struct Probe {
  const double* x[D];               // slot positions, one array per axis
  const double* radius;             // slot radii
  const std::uint32_t* member;      // slot -> particle index
  std::uint32_t p;                  // the particle
  double xp[D], rp;                 // its position and radius
  double reach_extra;               // interaction range + skin
  double half[D], period[D];        // minimum image per axis (open axes: half = inf, period = 0)
};

// Pairs found are appended as (lower index, higher index, image): the image index into the list's
// shift table (sum (k_a + 1) 3^a) of the higher particle relative to the lower.
struct Finds {
  std::uint32_t* i;
  std::uint32_t* j;
  std::uint8_t* image;
};

// The slots must hold `slack` entries past `used + (e - b)` (the AVX-512 build stores whole vectors).
inline constexpr std::size_t slack = 8;

// Tests slots [b, e); `wraps`: some of them may be nearer through a periodic image (else every slot is
// its own nearest image). Returns the new count of finds.
template <int D>
std::size_t test_portable(const Probe<D>& q, std::uint32_t b, std::uint32_t e, bool wraps, const Finds& out,
                          std::size_t used) {
  constexpr int images = D == 3 ? 27 : 9;
  for (std::uint32_t s = b; s < e; ++s) {   // branch-free: every candidate is written, `used` moves on a hit
    double d2 = 0;
    int img = images / 2;   // the unshifted image
    if (wraps) {
      img = 0;
      for (int a = D - 1; a >= 0; --a) {   // positions are wrapped, so |r_a| < L_a
        const double raw = q.x[a][s] - q.xp[a];
        const bool below = raw < -q.half[a], above = raw > q.half[a];
        const double r = raw + (below ? q.period[a] : 0.0) - (above ? q.period[a] : 0.0);
        img = img * 3 + 1 + below - above;
        d2 += r * r;
      }
    } else {
      for (int a = D - 1; a >= 0; --a) {
        const double r = q.x[a][s] - q.xp[a];
        d2 += r * r;
      }
    }
    const double cut = q.rp + q.radius[s] + q.reach_extra;
    const std::uint32_t m = q.member[s];
    const bool reversed = m < q.p;   // stored under the lower index, with the opposite image
    out.i[used] = reversed ? m : q.p, out.j[used] = reversed ? q.p : m;
    out.image[used] = std::uint8_t(reversed ? images - 1 - img : img);
    used += d2 < cut * cut;
  }
  return used;
}

// The AVX-512 build (candidate_test_avx512.cpp); only where pair_filter::avx512() is true.
template <int D>
std::size_t test_avx512(const Probe<D>& q, std::uint32_t b, std::uint32_t e, bool wraps, const Finds& out,
                        std::size_t used);

}  // namespace grains::candidate_test
