// Verlet neighbour list: every pair whose surfaces are closer than `reach` (interaction range + skin),
// stored once, under the lower index, rows sorted by partner (CSR). Built from a hierarchy of cell grids
// (one per factor-two size class) so that a size ratio of 10 costs about as much as monodisperse.
#pragma once
#include <cstdint>
#include <vector>

#include "core/box.hpp"
#include "core/byte_stream.hpp"

namespace grains {

template <int D>
class NeighbourList {
 public:
  // `range`: surface gap up to which a pair interacts (0 for plain contact); `skin`: extra margin.
  void configure(double range, double skin) { range_ = range, skin_ = skin; }
  double skin() const { return skin_; }

  // Positions must already be wrapped into the box. Remembers the previous list so per-pair history
  // can be carried over with carry().
  void build(const std::vector<Vec<D>>& position, const std::vector<double>& radius, const Box<D>& box, int threads);
  // True once some particle has moved more than skin/2 since the last build (less the part of the skin
  // that the cell deformation since the build has used up, see follow_cell).
  bool stale(const std::vector<Vec<D>>& position) const;
  // The periodic cell was rescaled by `scale` per axis about box.lower and the particles followed
  // affinely: image shifts follow the new lengths and the reference positions the affine map, so
  // stale() sees only the motion relative to the cell. A pair's separation changes by at most
  // |scale - 1| times the list reach, which the staleness test charges against the skin.
  void follow_cell(const Vec<D>& scale, const Box<D>& box);

  std::size_t pair_count() const { return partner.size(); }
  long builds() const { return builds_; }

  // Move per-pair values from the previous list to the current one; new pairs get `fresh`.
  template <class T> void carry(std::vector<T>& values, const T& fresh) const {
    std::vector<T> next(partner.size(), fresh);
    for (std::size_t k = 0; k < partner.size(); ++k)
      if (previous_entry_[k] >= 0 && std::size_t(previous_entry_[k]) < values.size()) next[k] = values[previous_entry_[k]];
    values.swap(next);
  }

  void save(ByteWriter& w) const;
  void load(ByteReader& r);

  std::vector<std::uint32_t> start;    // row i is [start[i], start[i+1])
  std::vector<std::uint32_t> partner;  // j > i? not necessarily: stored under min(i, j), so always j > i
  std::vector<std::uint8_t> image;     // index into shift: x_j + shift[image] - x_i is the pair vector
  std::vector<Vec<D>> shift;           // 3^D periodic image shifts

 private:
  double range_ = 0, skin_ = 0.1;
  long builds_ = 0;
  std::vector<Vec<D>> reference_;      // positions at the last build
  Vec<D> strain_since_build_ = Vec<D>::Ones();   // cell length now / at the last build, per axis
  double list_reach_ = 0;              // largest centre distance a listed pair may have: 2 R_max + range + skin
  std::vector<std::int64_t> previous_entry_;
};

}  // namespace grains
