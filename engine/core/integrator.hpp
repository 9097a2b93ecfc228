// Velocity Verlet for translation and rotation, split around the force evaluation.
// Between the two halves, `velocity` holds v(t + h/2) (which moved the positions and feeds the
// tangential springs) and `velocity_predicted` a third-order estimate of v(t + h) for the dashpots:
//   v(t+h) ~ v(t+h/2) + h/2 (7/4 a_n - 3/4 a_{n-1}).
#pragma once
#include <cmath>

#include "core/particles.hpp"

namespace grains {

template <int D>
void kick_drift_predict(Particles<D>& P, double h, int threads) {
  const std::size_t N = P.size();
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::size_t i = 0; i < N; ++i) {
    P.velocity[i] += 0.5 * h * P.accel[i];
    P.position[i] += h * P.velocity[i];
    P.velocity_predicted[i] = P.velocity[i] + 0.5 * h * (1.75 * P.accel[i] - 0.75 * P.accel_prev[i]);
    P.angular_velocity[i] += 0.5 * h * P.angular_accel[i];
    P.angular_velocity_predicted[i] =
        P.angular_velocity[i] + 0.5 * h * (1.75 * P.angular_accel[i] - 0.75 * P.angular_accel_prev[i]);
    if constexpr (D == 3) {
      const double w = P.angular_velocity[i].norm();
      if (w > 0) {
        P.orientation[i] = Eigen::Quaterniond(Eigen::AngleAxisd(w * h, P.angular_velocity[i] / w)) * P.orientation[i];
        P.orientation[i].normalize();
      }
    } else {
      P.orientation[i] += h * P.angular_velocity[i][0];
    }
  }
}

// Second half kick from the new forces. Returns the sum of all velocities' components, a cheap
// witness: it is finite exactly when every velocity is.
template <int D>
double finish_kick(Particles<D>& P, double h, int threads) {
  const std::size_t N = P.size();
  double witness = 0;
#pragma omp parallel for num_threads(threads) schedule(static) reduction(+ : witness)
  for (std::size_t i = 0; i < N; ++i) {
    P.accel_prev[i] = P.accel[i];
    P.accel[i] = P.inv_mass[i] * P.force[i];
    P.velocity[i] += 0.5 * h * P.accel[i];
    P.angular_accel_prev[i] = P.angular_accel[i];
    P.angular_accel[i] = P.inv_inertia[i] * P.torque[i];
    P.angular_velocity[i] += 0.5 * h * P.angular_accel[i];
    witness += P.velocity[i].sum() + P.position[i].sum() + P.angular_velocity[i].sum();
  }
  return witness;
}

}  // namespace grains
