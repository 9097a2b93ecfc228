// F0, the force unit of a pressure-controlled cell's P* and of its equilibrium test: cell.force_unit when the
// scene gives it, else the adhesion's force when adhesion is on (0: cohesionless, P* = P a^(D-2) / k_n). Without
// adhesion a cell must give it (refused at set-up); the 1 below only serves checks made before that.
#pragma once
#include "io/scene.hpp"

namespace grains {

inline double cell_force_unit(const Scene& scene) {
  return scene.has("cell.force_unit")        ? scene.real("cell.force_unit")
         : scene.boolean("adhesion.enabled") ? scene.real("adhesion.force")
                                             : 1.0;
}

}  // namespace grains
