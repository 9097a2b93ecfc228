// The tangential law's parameters, beside the rolling law's (rolling_resistance.hpp); the pair loop
// (contact_forces.hpp, tangential_force) evaluates them.
#pragma once

namespace grains {

struct NoFriction {
  static constexpr bool enabled = false;
};

// Incremental tangential spring with Coulomb bound (physics.md section 4).
struct CoulombFriction {
  static constexpr bool enabled = true;
  double mu = 0.5;
  double stiffness_ratio = 1.0;   // k_t / k_n
  double damping_ratio = 0.0;     // c_t / c_n
  bool elastic_bound = false;     // bound on k_n delta (true) or on the full normal force (false)
};

}  // namespace grains
