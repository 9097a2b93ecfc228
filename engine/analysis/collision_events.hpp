// Collision event log (physics.md section 8): every contact event with its start and end times and
// its impact and rebound normal speeds, and whether it was adhesive.
//
// An event starts when the surfaces of a pair first touch. It ends
//   - as a rebound when the surfaces separate again (rebound speed = receding normal speed then), or
//   - as an adhesive collision when the pair, still touching, stops separating: after the pair has
//     started to recede (relative normal velocity v_n > 0), v_n falls back to <= 0. A pair held
//     together (by gravity, by damping that stops it inside the overlap, or by its neighbours) ends
//     here; its rebound speed is recorded as 0 ("the particles remain in contact after impact",
//     zero total restitution, in the aggregation paper's words).
// A pair that stays touching after an adhesive event starts no new event until it has separated.
// Events still open when the run stops are counted apart (`open_collision_count`), not in the
// fraction. Pairs already touching in the initial state start no event until they separate.
//
// The log scans the neighbour list's pairs after each step (synchronised velocities v(t + h)); the
// scene switches it on (`analysis.collision_log`), otherwise it is not constructed.
#pragma once
#include <cstdint>
#include <vector>

#include "analysis/collision_event.hpp"
#include "core/byte_stream.hpp"
#include "core/system.hpp"

namespace grains {

template <int D>
class CollisionLog {
 public:
  // Scan every listed pair after a step of length h that ended at s.time.
  void after_step(const System<D>& s, double h);
  // The neighbour list was rebuilt: re-index the per-pair state.
  void after_rebuild(const NeighbourList<D>& list);

  long collisions() const { return long(events_.size()) - open_; }   // completed events
  long adhesive() const { return adhesive_; }
  long open() const { return open_; }
  // Every event in the order they started; open ones have end = NaN.
  const std::vector<CollisionEvent>& events() const { return events_; }

  void save(ByteWriter& w) const;
  void load(ByteReader& r);
  // After a whole state is loaded: throws if the per-pair states do not fit the saved list.
  void check_loaded(const NeighbourList<D>& list) const;

 private:
  enum Phase : std::int64_t { unknown, apart, approaching, receding, resting };   // a full word: no padding
  struct PairState {
    double gap = 0, normal_speed = 0;   // at the end of the last step
    std::int64_t event = -1;            // index into events_ while an event is open
    Phase phase = unknown;
  };
  void close(PairState& p, double end, double rebound, bool adhesive);

  std::vector<PairState> pairs_;        // aligned with the neighbour list
  std::vector<CollisionEvent> events_;
  long adhesive_ = 0, open_ = 0;
};

extern template class CollisionLog<2>;
extern template class CollisionLog<3>;

}  // namespace grains
