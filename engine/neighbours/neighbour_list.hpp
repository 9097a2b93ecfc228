// Verlet neighbour list: every pair whose surfaces are closer than `reach` (interaction range + skin),
// stored once, under the lower index (CSR). Built from a hierarchy of cell grids (one per factor-two
// size class) so that a size ratio of 10 costs about as much as monodisperse. Rows are in the
// (deterministic) order of discovery. History of a few pairs (the contacts) follows the pairs with
// match_previous(); history of every pair with carry(), which needs configure(..., history = true):
// each entry is then matched against the previous list's row (the rows' order stays that of discovery,
// with or without history, so that the forces summed in row order do not depend on it).
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/box.hpp"
#include "core/byte_stream.hpp"
#include "neighbours/candidate_test.hpp"

namespace grains {

// The staleness test of a Verlet list and of its shell: a margin (skin or shell thickness) is used up
// once some particle has moved more than margin/2 since the build, less what the cell strain since has
// used of it (charged over the largest centre distance `reach` a listed pair may have).
template <int D>
bool margin_used_up(double margin, const Vec<D>& strain_since_build, double reach, double largest_move) {
  const double strain = (strain_since_build.array() - 1).abs().maxCoeff();
  const double allowance = 0.5 * (margin - strain * reach);   // per particle
  return allowance <= 0 || largest_move > allowance * allowance;
}

template <int D>
class NeighbourList {
 public:
  // `range`: surface gap up to which a pair interacts (0 for plain contact); `skin`: extra margin;
  // `history`: carry() will be used (costs a sort of each old row and a look-up per entry per build).
  void configure(double range, double skin, bool history = false) { range_ = range, skin_ = skin, history_ = history; }
  double skin() const { return skin_; }

  // Positions must already be wrapped into the box. Keeps the previous list's rows for
  // match_previous(); with history, also maps every entry to the previous list for carry().
  void build(const std::vector<Vec<D>>& position, const std::vector<double>& radius, const Box<D>& box, int threads);
  // The list is stale once some particle has moved more than skin/2 since the last build (less the part
  // of the skin that the cell deformation since the build has used up, see follow_cell). The pass that
  // moves the particles measures their largest squared displacement from the reference positions, each
  // thread over its own share (core/integrator.hpp, DriftGeometry); stale_after judges the largest over
  // all shares.
  bool stale_after(double largest_move) const;
  // The positions at the last build, as the cell has carried them since: lower + (x - lower) * strain
  // per axis (strain 1: x itself). Null positions when the particle count is not the list's.
  struct Reference {
    const Vec<D>* position = nullptr;
    Vec<D> lower = Vec<D>::Zero(), strain = Vec<D>::Ones();
  };
  Reference reference(std::size_t particles) const {
    if (reference_.size() != particles) return {};
    return {reference_.data(), reference_lower_, strain_since_build_};
  }
  // The periodic cell was rescaled by `scale` per axis about box.lower and the particles followed
  // affinely: image shifts follow the new lengths and the reference positions the affine map, so
  // the measured moves are relative to the cell. A pair's separation changes by at most
  // |scale - 1| times the list reach, which the staleness test charges against the skin.
  void follow_cell(const Vec<D>& scale, const Box<D>& box);

  std::size_t pair_count() const { return partner.size(); }
  // The largest centre distance a listed pair may have: 2 R_max + range + skin.
  double reach() const { return list_reach_; }
  double range() const { return range_; }
  // The cell's strain since the last build, per axis (1: none).
  const Vec<D>& strain_since_build() const { return strain_since_build_; }
  long builds() const { return builds_; }
  // Candidates the last build tested (slots read by the distance test): about N times the particles
  // within a cell's neighbourhood, however far apart the particles lie (tests check the build stays linear).
  std::size_t candidates_examined() const { return candidates_examined_; }

  // Move per-pair values from the previous list to the current one; new pairs get `fresh`.
  template <class T> void carry(std::vector<T>& values, const T& fresh) const {
    if (!history_) throw std::logic_error("NeighbourList::carry() needs configure(range, skin, history = true)");
    std::vector<T> next(partner.size(), fresh);
    for (std::size_t k = 0; k < partner.size(); ++k)
      if (previous_entry_[k] >= 0 && std::size_t(previous_entry_[k]) < values.size()) next[k] = values[previous_entry_[k]];
    values.swap(next);
  }

  // Calls move(old, k) for every entry `old` of the previous list that keep(old) selects and that is
  // listed again, at entry k. Each kept entry scans its new row: cheap for a few entries (the
  // contacts), and the rows need no sorting.
  template <class Keep, class Move> void match_previous(Keep keep, Move move) const {
    const std::size_t rows = std::min(previous_start_.size(), start.size());
    for (std::size_t i = 0; i + 1 < rows; ++i)
      for (std::size_t old = previous_start_[i]; old < previous_start_[i + 1]; ++old)
        if (keep(old))
          for (std::size_t k = start[i]; k < start[i + 1]; ++k)
            if (partner[k] == previous_partner_[old]) {
              move(old, k);
              break;
            }
  }

  void save(ByteWriter& w) const;
  void load(ByteReader& r);

  std::vector<std::uint32_t> start;    // row i is [start[i], start[i+1])
  std::vector<std::uint32_t> partner;  // j > i? not necessarily: stored under min(i, j), so always j > i
  std::vector<std::uint8_t> image;     // index into shift: x_j + shift[image] - x_i is the pair vector
  std::vector<std::uint32_t> owner;    // the row i of each entry (for loops that run over entries, not rows)
  std::vector<Vec<D>> shift;           // 3^D periodic image shifts

 private:
  void fill_owners();   // owner from start
  // One uniform grid of cells holding the particles of one size class, counting-sorted by cell, with
  // positions (an array per axis) and radii copied in cell order so that the candidate test reads
  // memory in sequence (candidate_test.hpp). Dense: the cells tile the extent (an array of them).
  // Hashed, when a dense grid coarsened to its budget of about 4N cells (an open box whose grains spread
  // thin) came out crowded (a grain far from the rest: the others in a few cells, N^2 candidates): cells
  // of the reach's size keyed by their integer coordinates (unbounded along open axes) into a table of
  // 2 to 4 buckets per member, so that the cost stays linear in N whatever the spread.
  struct Grid {
    Vec<D> origin, inverse_cell;
    std::array<int, D> n{};   // cells per axis (hashed: along periodic axes only)
    bool hashed = false;
    std::uint64_t bucket_mask = 0;   // hashed: buckets - 1
    std::vector<std::uint32_t> cell_start, members;   // cell_start per cell, or per bucket
    std::array<std::vector<double>, D> member_x;
    std::vector<double> member_radius;
    double max_radius = 0;
    int flat(const std::array<int, D>& c) const;
    std::array<int, D> coords(const Vec<D>& x) const;
    std::array<std::int64_t, D> key(const Vec<D>& x) const;            // hashed: the cell's coordinates
    std::uint32_t bucket(const std::array<std::int64_t, D>& k) const;  // hashed: its bucket
  };
  // One thread's finds: pairs (i < j) with the image of j relative to i, in order of discovery.
  struct Found {
    std::vector<std::uint32_t> i, j;
    std::vector<std::uint8_t> image;
    std::size_t examined = 0;   // candidates tested
  };
  void search(const Grid& g, std::uint32_t first, std::uint32_t p, const Vec<D>& xp, double rp, const Box<D>& box,
              bool wide, Found& out, std::size_t& used) const;
  void search_hashed(const Grid& g, std::uint32_t first, const candidate_test::Probe<D>& probe, const Vec<D>& xp,
                     const Box<D>& box, bool wide, Found& out, std::size_t& used) const;

  double range_ = 0, skin_ = 0.1;
  bool history_ = false;
  long builds_ = 0;
  std::size_t candidates_examined_ = 0;
  std::vector<Vec<D>> reference_;      // positions at the last build
  Vec<D> strain_since_build_ = Vec<D>::Ones();   // cell length now / at the last build, per axis
  Vec<D> reference_lower_ = Vec<D>::Zero();      // the corner the cell is scaled about (follow_cell)
  double list_reach_ = 0;              // largest centre distance a listed pair may have: 2 R_max + range + skin
  std::vector<std::int64_t> previous_entry_;   // with history: index of each pair in the previous list, or -1
  std::vector<std::uint32_t> previous_start_, previous_partner_;   // the list before the last build
  // Scratch kept between builds (no reallocation per build).
  std::vector<Grid> grids_;
  std::vector<std::uint8_t> class_of_;
  std::vector<std::uint32_t> cell_of_, fill_;
  std::vector<Found> found_;   // per thread: the first found_count_[t] entries are pairs
  std::vector<std::size_t> found_count_;
};

}  // namespace grains
