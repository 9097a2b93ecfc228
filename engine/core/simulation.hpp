// The one seam between the engine and everything else (runner, FMU, checkpoints, tests).
// Built from a resolved scene; time advances only through step(); reading never changes state.
#pragma once
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/collision_event.hpp"
#include "core/variables.hpp"
#include "protocols/preparation_progress.hpp"

namespace grains {

class Scene;

// Thrown when the simulation cannot continue (non-finite value, invalid request). The message
// names what went wrong, where (particle, step) and, for bad values, what is allowed.
struct SimulationError : std::runtime_error { using std::runtime_error::runtime_error; };

// Per-particle data exposed read-only for writers and analysis (copies, in SoA layout).
struct ParticleView {
  int dimension = 3;
  std::size_t count = 0;
  std::vector<double> position;         // count * dimension, wrapped into the primary box
  // count * dimension, with a periodic axis only (else empty): the cell lengths the wrapping took off, so that
  // position + image * box length is the particle's unwrapped position (H5MD's particles/<group>/image).
  std::vector<std::int64_t> image;
  std::vector<double> velocity;         // count * dimension
  std::vector<double> angular_velocity; // count * (dimension == 3 ? 3 : 1)
  std::vector<double> orientation;      // 3D: count * 4 quaternions (w, x, y, z); 2D: count angles; empty if not tracked
  std::vector<double> radius, mass;     // count each
  std::vector<double> force;            // count * dimension, total force from the last evaluation
};

struct BoxView {
  int dimension = 3;
  std::vector<double> lower, length;    // per axis
  std::vector<bool> periodic;           // per axis
};

class Simulation {
 public:
  // The most steps one request may take (a scene's run, a host's step): the step counter's range with
  // room to spare; a run of more would not end anyway.
  static constexpr double max_steps = 1e15;   // (its messages write it out: 1e15)

  virtual ~Simulation() = default;

  // Build from a validated scene; throws SceneError / SimulationError with a clear message. `progress`, where
  // given, hears how a long preparation (random insertion) goes.
  static std::unique_ptr<Simulation> create(const Scene& scene, const PreparationProgress& progress = {});

  // Advance by `duration` using the scene's internal step dt; a remainder that is not a whole
  // number of dt is taken as one shorter final step, so time lands exactly on t + duration.
  virtual void step(double duration) = 0;
  // Advance exactly n internal steps of the scene's dt.
  virtual void step_n(long n) = 0;
  // Advance by `duration` in n equal steps of duration / n, the last landing exactly on t + duration: a host's
  // step that is not a whole number of dt, without a short step beside whole ones (see fmu/instance.cpp).
  virtual void step_evenly(double duration, long n) = 0;

  virtual double time() const = 0;
  virtual long step_count() const = 0;
  virtual double dt() const = 0;
  virtual int dimension() const = 0;
  virtual int threads() const = 0;   // worker threads in use
  virtual std::size_t particle_count() const = 0;

  // Named variables: parameters, inputs, outputs. Index = position in variables().
  virtual const std::vector<VariableInfo>& variables() const = 0;
  virtual double get(std::size_t index) const = 0;
  virtual void set(std::size_t index, double value) = 0;   // throws on bad value / fixed parameter
  double get(const std::string& name) const { return get(index_of(name)); }
  void set(const std::string& name, double value) { set(index_of(name), value); }
  std::size_t index_of(const std::string& name) const;
  bool has(const std::string& name) const;   // a variable of that name (one a scene's options add, say)

  // Complete state as bytes; restore_state(save_state()) continues bit-identically.
  virtual std::vector<std::byte> save_state() const = 0;
  virtual void restore_state(std::span<const std::byte> state) = 0;

  virtual ParticleView particles() const = 0;
  virtual BoxView box() const = 0;

  // The collision log (scene key analysis.collision_log): every contact event so far, in the order
  // they started (open ones have end = NaN); empty when the log is off.
  virtual std::vector<CollisionEvent> collision_events() const { return {}; }

  // Warnings raised while building or running (time step too large, clamped overlaps...).
  virtual const std::vector<std::string>& warnings() const = 0;
};

}  // namespace grains
