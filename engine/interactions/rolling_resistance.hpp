// Rolling resistance (physics.md section 5): the relative rotation of the two grains (its rolling
// part, perpendicular to n in 3D) accumulates per contact like the tangential spring; the moment
// Gamma_R = -K_R theta_R acts on j and its opposite on i (a pure couple: angular momentum is kept),
// bounded by mu_R F_N^e; beyond the bound theta_R is rescaled so |K_R theta_R| = mu_R F_N^e.
// A rolling dashpot -c_r (w_j - w_i), c_r = damping * c_n R_i R_j, damps the relative spin: without
// it a loose frictional network keeps undamped rolling mechanisms (no normal or sliding motion at
// any contact, so no other dashpot sees them) and never reaches the equilibrium criteria.
#pragma once

namespace grains {

struct NoRolling {
  static constexpr bool enabled = false;
};

struct RollingResistance {
  static constexpr bool enabled = true;
  double stiffness = 0;     // K_R (force * length / radian)
  double coefficient = 0;   // mu_R (length): |Gamma_R| <= mu_R K_N delta; K_R = 0: no rolling spring
  double damping = 0;       // c_r / (c_n R_i R_j)
};

}  // namespace grains
