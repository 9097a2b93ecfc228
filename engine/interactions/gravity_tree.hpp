// Barnes-Hut tree for softened gravity (physics.md section 7), without G: the sums of gravity_direct.hpp with
// far cells replaced by their monopole + quadrupole expansion.
// Build: the particles are sorted along a Morton (Z-order) curve and copied in that order, so every cell of
// the 2^D-ary tree holds one contiguous run of them; a cell of more than `leaf_size` particles is split.
// Moments are formed bottom-up (children's by the parallel-axis rule).
// Walk: one traversal per group (the largest cells of at most `group_size` particles) serves all its
// particles; an opened cell's children are tested together (in vectors on AVX-512 and AVX2). A cell is used whole when its centre of mass lies farther than max(s / theta, b_max) from the
// group's bounding box, s being the longest edge of the cell's particles' bounding box (not of the
// geometric cell) and b_max the distance from the centre of mass to that box's farthest corner, and does
// not hold the group; otherwise it is opened, and the particles of the leaves reached are summed one by one. Used whole for the group
// means used whole for each of its particles under the same rule per particle, so the group walk is never
// coarser than a walk per particle at the same theta.
// Every particle of the group then runs over the two lists with an AVX-512 kernel, an AVX2 + FMA one or a
// portable one, picked at run time like gravity_direct. The portable kernel is FP64 throughout, with a
// correctly rounded square root and division. The vector kernels sum in FP32 (sixteen or eight entries at a
// time) from FP32 copies made when the tree is built (positions as float hi + lo, so that differences keep
// FP32 precision anywhere): their round-off, ~1e-7 of the terms' size, stays far below the expansion's
// truncation error (~1e-5 at theta 0.2, 2e-4 at 0.5). AVX2 takes 1 / h from the correctly rounded square root and
// division (the same bits on any maker's processor), AVX-512 from vrsqrt14ps and a Newton step. Below theta =
// fp32_min_theta, where the truncation error is no longer far above FP32 round-off, or where a softening or
// mass lies outside FP32's comfortable range, they keep FP64 (AVX-512: eight entries at a time, 1 / sqrt from
// a refined reciprocal square root within a few units in the last place, see gravity_avx512.hpp; AVX2: four,
// correctly rounded); for the cells alone when only the nearest pairs' distances are out of range. A
// particle's sum is formed in an order set by the tree and the kernel alone, so the result is bit-identical
// on any number of threads.
#pragma once
#include <array>
#include <cstddef>
#include <utility>
#include <vector>

#include "core/particles.hpp"
#include "interactions/gravity_direct.hpp"

namespace grains::gravity_tree {

using gravity_direct::Isa;

class Tree {
 public:
  // theta <= 0 opens every cell: direct summation, up to round-off.
  // From this theta on the vector kernels sum in FP32 (see above).
  static constexpr double fp32_min_theta = 0.2;
  // Built on `threads` threads where the work splits evenly (the same tree on any number).
  template <int D>
  Tree(const Particles<D>& P, double theta, int threads = 1, int leaf_size = 16, int group_size = 64);

  struct Counts {
    std::size_t particle_pairs = 0, particle_cells = 0;   // terms summed (ordered pairs, particle-cell)
  };
  // Accelerations (without G) and, if phi is given, potentials per unit mass (without G: -sum m_j / r),
  // indexed like the particles. In 2D az stays zero.
  Counts evaluate(Isa isa, double eps2, int threads, std::vector<double>& ax, std::vector<double>& ay,
                  std::vector<double>& az, std::vector<double>* phi) const;

  std::size_t group_count() const { return groups_.size(); }

  // What the walk of kernel set `isa` gives for group g (0 <= g < group_count()): the cells used whole and the
  // particle ranges (Morton order) summed one by one, in the order the lists take them, and the least squared
  // distance of a used cell to the group's box. For tests: every kernel set's walk must give the same.
  struct Walk {
    std::vector<int> cells;
    std::vector<std::pair<int, int>> ranges;
    double near2 = 0;
  };
  Walk walk(Isa isa, std::size_t g) const;

 private:
  struct Cell {
    std::array<double, 3> com, lo, hi;   // centre of mass, bounding box of the particles; z = 0 in 2D
    double mass = 0;
    double accept2 = 0;                  // max(s / theta, b_max)^2; infinite: always opened
    int first_child = -1, children = 0;  // children are stored together
    int begin = 0, end = 0;              // particles, in Morton order
  };
  // What the walk reads of the cells (a Cell takes 104 bytes), one array per field: the children of a cell
  // are stored together, so the vector walks test all of them at once.
  struct Nodes {
    std::vector<double> cx, cy, cz, accept2;
    std::vector<int> first_child, children, begin, end;
  };
  // Sum m (3 d d^T - |d|^2 I), d = x - com: xx, xy, xz, yy, yz, zz.
  using Quadrupole = std::array<double, 6>;

  template <int D>
  void build(int id, int begin, int end, int level, bool in_group, const std::vector<unsigned long long>& keys);
  void moments(int id);

  double theta_;
  // The FP32 copies' frame: positions relative to origin_ in units of len_, masses in units of mass_unit_
  // (len_ and mass_unit_ are powers of two near the root cube's edge and the total mass: exact scaling).
  std::array<double, 3> origin_{};
  double len_ = 1, mass_unit_ = 1;
  bool fp32_masses_ = false;              // FP32 copies made (theta >= fp32_min_theta, AVX2 or wider), every mass 0 or >= 1e-20 mass_unit_
  int leaf_size_, group_size_;
  std::vector<int> order_;                // order_[k] = particle index of the k-th in Morton order
  std::vector<double> x_, y_, z_, m_;     // positions and masses in Morton order
  std::vector<Cell> cells_;
  Nodes nodes_;                           // the walk's copy of cells_
  std::vector<Quadrupole> quad_;
  // What a cell used whole adds to the lists, in one record: com x, y, z, mass, quadrupole.
  using Multipole = std::array<double, 10>;
  std::vector<Multipole> multipoles_;
  // Their FP32 copies: com x hi, x lo, y hi, y lo, z hi, z lo, mass, quadrupole.
  using Multipole32 = std::array<float, 13>;
  std::vector<Multipole32> multipoles32_;
  std::vector<float> xh_, xl_, yh_, yl_, zh_, zl_, m32_;   // FP32 copies of the particles, Morton order
  std::vector<int> groups_;               // cells walked for, in Morton order
};

extern template Tree::Tree(const Particles<2>&, double, int, int, int);
extern template Tree::Tree(const Particles<3>&, double, int, int, int);

}  // namespace grains::gravity_tree
