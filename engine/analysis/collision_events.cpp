#include "analysis/collision_events.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace grains {

template <int D>
void CollisionLog<D>::after_rebuild(const NeighbourList<D>& list) {
  list.carry(pairs_, PairState{});
}

template <int D>
void CollisionLog<D>::close(PairState& p, double end, double rebound, bool adhesive) {
  CollisionEvent& e = events_[std::size_t(p.event)];
  e.end = end;
  e.rebound_speed = rebound;
  e.adhesive = adhesive;
  adhesive_ += adhesive;
  --open_;
  p.event = -1;
}

template <int D>
void CollisionLog<D>::after_step(const System<D>& s, double h) {
  const auto& P = s.particles;
  const auto& nl = s.neighbours;
  pairs_.resize(nl.pair_count());
  const double t = s.time, t0 = s.time - h;
  // Time at which the gap crossed zero, linear between the gaps before and after the step.
  auto crossing = [&](double before, double after) {
    return before == after ? t : t0 + h * std::clamp(before / (before - after), 0.0, 1.0);
  };
  for (std::size_t i = 0; i + 1 < nl.start.size(); ++i)
    for (auto k = nl.start[i]; k < nl.start[i + 1]; ++k) {
      const auto j = nl.partner[k];
      const Vec<D> r = P.position[j] + nl.shift[nl.image[k]] - P.position[i];
      const double d = r.norm();
      const double gap = d - P.radius[i] - P.radius[j];
      const double vn = (P.velocity[j] - P.velocity[i]).dot(r) / d;   // > 0: receding
      const bool touching = gap < 0;
      PairState& p = pairs_[k];
      if (p.phase == unknown) {
        // A pair new to the list (it may enter at the very step it touches): its state before this
        // step, from the positions it moved by h v(t + h/2) and the velocities v(t).
        auto half = [&](std::size_t m) { return Vec<D>(P.velocity[m] - 0.5 * h * (P.inv_mass[m] * P.force[m])); };
        auto start = [&](std::size_t m) { return Vec<D>(half(m) - 0.5 * h * (P.inv_mass[m] * P.force_prev[m])); };
        const Vec<D> r0 = r - h * (half(j) - half(i));
        const double d0 = r0.norm();
        p.gap = d0 - P.radius[i] - P.radius[j];
        p.normal_speed = (start(j) - start(i)).dot(r0) / d0;
        p.phase = p.gap < 0 ? resting : apart;
      }
      switch (p.phase) {
        case unknown: break;
        case apart:
          if (!touching) break;
          p.event = std::int64_t(events_.size());
          events_.push_back({std::uint32_t(i), std::uint32_t(j), crossing(p.gap, gap), std::numeric_limits<double>::quiet_NaN(),
                             std::max(0.0, -p.normal_speed), 0.0, 0});
          ++open_;
          p.phase = vn > 0 ? receding : approaching;
          break;
        case approaching:
          if (!touching) close(p, crossing(p.gap, gap), std::max(0.0, vn), false), p.phase = apart;
          else if (vn > 0) p.phase = receding;
          break;
        case receding:
          if (!touching) close(p, crossing(p.gap, gap), std::max(0.0, vn), false), p.phase = apart;
          else if (vn <= 0) close(p, t, 0.0, true), p.phase = resting;   // stopped separating while touching
          break;
        case resting:
          if (!touching) p.phase = apart;
          break;
      }
      p.gap = gap;
      p.normal_speed = vn;
    }
}

template <int D>
void CollisionLog<D>::save(ByteWriter& w) const {
  w.put_vector(pairs_);
  w.put_vector(events_);
  w.put(adhesive_), w.put(open_);
}

template <int D>
void CollisionLog<D>::load(ByteReader& r) {
  r.get_vector(pairs_);
  r.get_vector(events_);
  adhesive_ = r.get<long>(), open_ = r.get<long>();
}

template <int D>
void CollisionLog<D>::check_loaded(const NeighbourList<D>& list) const {
  bool ok = pairs_.size() == list.pair_count() || pairs_.empty();
  for (const PairState& p : pairs_)
    ok = ok && p.event >= -1 && p.event < std::int64_t(events_.size()) && p.phase >= unknown && p.phase <= resting;
  if (!ok) throw std::runtime_error("saved collision log does not fit the saved neighbour list");
}

template class CollisionLog<2>;
template class CollisionLog<3>;

}  // namespace grains
