#include "neighbours/shell_list.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "interactions/pair_filter.hpp"

namespace grains {

// The cost of a shell of thickness h per step: testing its S(h) pairs, plus a selection (a pass over the
// L listed pairs, then the copies: about 1.5 L) every (h/2) / v steps, v the largest move per step. S(h)
// grows about linearly from the last shell's size at its thickness to L at the skin, with slope s; the
// sum S(h) + 1.5 L 2 v / h is least at h = sqrt(3 v L / s). v comes from the last shell's life.
template <int D>
void ShellList<D>::choose_thickness(std::size_t listed, long life) {
  if (life <= 0 || thickness_ >= skin_) return;
  const double v = 0.5 * thickness_ / double(life);
  const double slope = std::max(1.0, double(listed) - double(entry.size())) / (skin_ - thickness_);
  thickness_ = std::clamp(std::sqrt(3 * v * double(listed) / slope), skin_ / 64, skin_ / 2);
}

template <int D>
void ShellList<D>::build(const NeighbourList<D>& list, const std::vector<Vec<D>>& position, const std::vector<double>& radius,
                         double list_move, long step, bool expired) {
  const std::size_t rows = list.start.empty() ? 0 : list.start.size() - 1;
  const std::size_t listed = list.pair_count();
  if (adaptive_ && expired && built_) choose_thickness(listed, step - built_at_);
  // The pair filter with the shell as its attraction tail: the entries within range + thickness.
  const pair_filter::Geometry<D> g{position.data(), radius.data(), list.partner.data(), list.owner.data(),
                                   list.image.data(), list.shift.data(), list.range() + thickness_};
  entry.resize(listed + pair_filter::slack), owner.resize(listed + pair_filter::slack), image.resize(listed + pair_filter::slack);
  const std::size_t n = rows ? pair_filter::gather<D>(g, list.start.data(), 0, rows, owner.data(), entry.data(), image.data()) : 0;
  entry.resize(n), owner.resize(n), image.resize(n);
  partner.resize(n);
  for (std::size_t m = 0; m < n; ++m) partner[m] = list.partner[entry[m]];
  start.assign(rows + 1, 0);
  for (std::size_t m = 0; m < n; ++m) ++start[owner[m] + 1];
  for (std::size_t i = 0; i < rows; ++i) start[i + 1] += start[i];
  list_reach_ = list.reach();
  list_move_ = list_move;
  reference_ = position;
  strain_since_build_.setOnes();
  built_ = true;
  built_at_ = step;
  ++builds_;
}

template <int D>
bool ShellList<D>::stale_after(double largest_move) const {
  return margin_used_up<D>(thickness_, strain_since_build_, list_reach_, largest_move);
}

template <int D>
double ShellList<D>::list_move_bound(double largest_move) const {
  // A margin far above the rounding of the measured moves (a few ulps of the coordinates).
  const double margin = 1e-9 * (1 + list_reach_);
  const double bound = std::sqrt(largest_move) + strain_since_build_.maxCoeff() * list_move_ + margin;
  return bound * bound;
}

template <int D>
void ShellList<D>::save(ByteWriter& w) const {
  w.put(thickness_), w.put(built_), w.put(builds_), w.put(built_at_);
  w.put(list_reach_), w.put(list_move_), w.put(strain_since_build_), w.put(reference_lower_);
  w.put_vector(reference_), w.put_vector(start), w.put_vector(entry), w.put_vector(owner), w.put_vector(partner),
      w.put_vector(image);
}

template <int D>
void ShellList<D>::load(ByteReader& r) {
  thickness_ = r.get<double>(), built_ = r.get<bool>(), builds_ = r.get<long>();
  built_at_ = r.get<long>(), list_reach_ = r.get<double>(), list_move_ = r.get<double>();
  strain_since_build_ = r.get<Vec<D>>(), reference_lower_ = r.get<Vec<D>>();
  r.get_vector(reference_), r.get_vector(start), r.get_vector(entry), r.get_vector(owner), r.get_vector(partner),
      r.get_vector(image);
  // Its indices address arrays at the next step: a state that does not hold together is refused here.
  const auto refuse = [](const char* what) { throw std::runtime_error(std::string("saved shell list is inconsistent: ") + what); };
  const std::size_t n = entry.size(), rows = start.empty() ? 0 : start.size() - 1;
  if (owner.size() != n || partner.size() != n || image.size() != n) refuse("a row, partner and image per entry");
  if (start.empty() ? n != 0 : start.front() != 0 || start.back() != n) refuse("its rows do not cover its entries");
  // Every row in order before any is read: a later row's start below an earlier one's let that row run past the entries.
  for (std::size_t i = 0; i < rows; ++i)
    if (start[i] > start[i + 1]) refuse("rows out of order");
  for (std::size_t i = 0; i < rows; ++i) {
    for (std::uint32_t e = start[i]; e < start[i + 1]; ++e)
      if (owner[e] != i || partner[e] <= i || partner[e] >= rows || image[e] >= (D == 3 ? 27 : 9))
        refuse("an entry's row, partner or image out of range");
  }
  if (off_) {   // configured without a shell: as if it had never been built
    thickness_ = 0, built_ = false, builds_ = 0, built_at_ = 0, list_reach_ = 0, list_move_ = 0;
    strain_since_build_.setOnes(), reference_lower_.setZero();
    for (auto* v : {&start, &entry, &owner, &partner}) v->clear();
    reference_.clear(), image.clear();
  }
}

template class ShellList<2>;
template class ShellList<3>;

}  // namespace grains
