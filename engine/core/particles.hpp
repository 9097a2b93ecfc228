// Particle storage: one array per attribute (structure of arrays), D = 2 or 3.
#pragma once
#include <cstddef>
#include <vector>

#include "core/image.hpp"
#include "core/vec.hpp"

namespace grains {

template <int D>
struct Particles {
  using V = Vec<D>;
  using S = Spin<D>;
  std::vector<V> position, velocity, force;
  // The force of the evaluation before `force`'s: the velocity predictor needs a_n and a_{n-1}, and forms
  // both from the forces (core/integrator.hpp); between steps the two arrays swap roles.
  std::vector<V> force_prev;
  std::vector<V> velocity_predicted;         // v(t_{n+1}) estimate used by the dashpots
  // No predicted spin: every torque acts on the half-step spin (the tangential spring and the rolling parts).
  // No angular acceleration either: the torque, kept from one force evaluation to the next step's first
  // half, gives it (a stored copy was one more array to stream through the caches each step).
  std::vector<S> angular_velocity, torque;
  std::vector<Orientation<D>> orientation;
  std::vector<double> radius, mass, inv_mass, inertia, inv_inertia;
  // Bookkeeping only, never read by the dynamics: the cell lengths wrapping has taken off each position.
  std::vector<Image<D>> image;

  std::size_t size() const { return radius.size(); }

  void resize(std::size_t n) {
    for (auto* v : {&position, &velocity, &force, &force_prev, &velocity_predicted}) v->assign(n, V::Zero());
    for (auto* v : {&angular_velocity, &torque}) v->assign(n, S::Zero());
    if constexpr (D == 3) orientation.assign(n, Eigen::Quaterniond::Identity());
    else orientation.assign(n, 0.0);
    for (auto* v : {&radius, &mass, &inv_mass, &inertia, &inv_inertia}) v->assign(n, 0.0);
    image.assign(n, Image<D>{});
  }

  // Moment of inertia: solid sphere 2/5 m R^2, disk 1/2 m R^2.
  void set_mass_and_radius(std::size_t i, double m, double r) {
    radius[i] = r;
    mass[i] = m;
    inv_mass[i] = 1.0 / m;
    inertia[i] = (D == 3 ? 0.4 : 0.5) * m * r * r;
    inv_inertia[i] = 1.0 / inertia[i];
  }
};

}  // namespace grains
