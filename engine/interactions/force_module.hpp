// A force term the scene switches on. Modules the scene leaves off are never constructed.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "analysis/contact_network.hpp"
#include "analysis/elastic_spring.hpp"
#include "core/byte_stream.hpp"
#include "core/system.hpp"

namespace grains {

template <int D>
class ForceModule {
 public:
  virtual ~ForceModule() = default;
  virtual std::string name() const = 0;
  // Surface gap up to which this module needs neighbour pairs (negative: it does not use the list).
  virtual double pair_range() const { return -1; }
  // Whether this module applies torques (rotation is integrated only if some module does, or if
  // particles start spinning).
  virtual bool applies_torques() const { return false; }
  // Add this module's forces and torques into particles.force / particles.torque.
  virtual void add_forces(System<D>& s) = 0;
  // A step of length h begins (before its first half kick and drift) / ends (after its second half
  // kick): for corrections that act within one step (a contact's onset lag, contact_forces.hpp). Inside a
  // run of steps that second half kick may still be pending (core/pending_kick.hpp): call kick_early on a
  // particle before changing its velocity or spin here.
  virtual void begin_step(System<D>&, double /*h*/) {}
  virtual void finish_step(System<D>&) {}
  // The neighbour list was rebuilt: re-index per-pair history.
  virtual void after_rebuild(const NeighbourList<D>&) {}
  // Scalar observables of this module (name, value), read-only.
  virtual void observe(const System<D>&, std::vector<std::pair<std::string, double>>&) const {}
  // Pairs this module binds (contacts, distant bonds) with their static normal force; modules that
  // do not describe a contact network add nothing.
  virtual void list_interactions(const System<D>&, std::vector<NetworkInteraction>&) const {}
  // The same pairs linearised (stiffnesses, branch vectors, static forces), for the elastic moduli.
  virtual void list_springs(const System<D>&, std::vector<ElasticSpring<D>>&) const {}
  virtual void save(ByteWriter&) const {}
  virtual void load(ByteReader&) {}
  // After a whole state is loaded (the lists included): throws if what load read does not fit them.
  virtual void check_loaded(const System<D>&) const {}
};

}  // namespace grains
