// The Verlet list's entries within a thin shell: the pairs whose gap is below range + thickness, a
// selection of the list's entries in list order, rebuilt from the list (not from a cell search) when a
// particle has moved thickness/2 since. The pair loop tests these for contact each step instead of
// every listed pair (in the gas scenes about a quarter as many, on dense cohesive disks 60-85 %). It changes
// only how many pairs are tested, never which interact or in what order, so results are bit for bit
// those without it; the list itself is rebuilt exactly when it would be without the shell
// (Simulation: an upper bound from the shell's moves, then the list's own measure where the bound
// cannot decide).
#pragma once
#include <cstdint>
#include <vector>

#include "core/box.hpp"
#include "core/byte_stream.hpp"
#include "neighbours/neighbour_list.hpp"

namespace grains {

template <int D>
class ShellList {
 public:
  // thickness 0: no shell (the pair loop tests every listed pair). Adaptive: `thickness` is the first
  // build's; each build then picks the next from the last shell's life (choose_thickness).
  void configure(double thickness, bool adaptive, double skin) {
    thickness_ = thickness, adaptive_ = adaptive, skin_ = skin, built_ = false, off_ = thickness <= 0;
  }
  double thickness() const { return thickness_; }
  bool enabled() const { return thickness_ > 0; }
  // Built for the current list.
  bool built() const { return built_; }

  // The list's entries whose gap is below the list's range + thickness now, in list order. Positions
  // as the list's (wrapped at its build, carried with the cell since); `list_move`: the largest distance
  // of any particle from the list's reference positions (as carried), now.
  // `step`: the step count now; `expired`: the last shell went stale (not replaced with a new list).
  void build(const NeighbourList<D>& list, const std::vector<Vec<D>>& position, const std::vector<double>& radius,
             double list_move, long step, bool expired);
  // Like NeighbourList::stale_after: some particle has moved more than thickness/2 since the build, less
  // what the cell strain since has used up of it (charged over the list's reach: pairs outside the shell
  // may be as far apart as the list's).
  bool stale_after(double largest_move) const;
  // An upper bound on the largest squared move from the list's reference positions, given the largest
  // squared move from the shell's: |x - x_list| <= |x - x_shell| + s |x_shell - x_list| at the shell's
  // build, s the largest strain factor since (both references ride the same affine map).
  double list_move_bound(double largest_move) const;
  typename NeighbourList<D>::Reference reference(std::size_t particles) const {
    if (!built_ || reference_.size() != particles) return {};
    return {reference_.data(), reference_lower_, strain_since_build_};
  }
  // The cell was rescaled by `scale` about box.lower (NeighbourList::follow_cell).
  void follow_cell(const Vec<D>& scale, const Box<D>& box) {
    reference_lower_ = box.lower;
    strain_since_build_ = strain_since_build_.cwiseProduct(scale);
  }
  // The whole shell but what configure sets (a state restored into a scene without a shell leaves it
  // off): a restored run selects it again at the same steps, with the same thicknesses, so its counters
  // continue exactly.
  void save(ByteWriter& w) const;
  void load(ByteReader& r);

  std::size_t pair_count() const { return entry.size(); }
  long builds() const { return builds_; }

  // Row i's shell entries are [start[i], start[i+1]); per shell entry its list entry, row, partner and image.
  std::vector<std::uint32_t> start, entry, owner, partner;
  std::vector<std::uint8_t> image;

 private:
  // The adaptive thickness for the next shell, from the one that just expired after `life` steps.
  void choose_thickness(std::size_t listed, long life);

  double thickness_ = 0, skin_ = 0;
  bool adaptive_ = false, built_ = false, off_ = true;   // off_: configured without a shell
  long built_at_ = 0;           // the step of the last build
  long builds_ = 0;
  double list_reach_ = 0;       // the list's: the largest centre distance a listed pair may have
  double list_move_ = 0;        // the largest distance from the list's reference positions at the build
  std::vector<Vec<D>> reference_;   // positions at the build
  Vec<D> strain_since_build_ = Vec<D>::Ones(), reference_lower_ = Vec<D>::Zero();
};

}  // namespace grains
