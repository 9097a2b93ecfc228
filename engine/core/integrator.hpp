// Velocity Verlet for translation and rotation, split around the force evaluation.
// Between the two halves, `velocity` holds v(t + h/2) (which moved the positions and feeds the
// tangential springs) and `velocity_predicted` a third-order estimate of v(t + h) for the dashpots:
//   v(t+h) ~ v(t+h/2) + h/2 (7/4 a_n - 3/4 a_{n-1}).
#pragma once
#include <cmath>

#include "core/particles.hpp"

namespace grains {

// The rotation by angle |w| h about w, as a quaternion. Per-step angles are tiny, where the series
// (exact to double precision below 1e-2) avoids a sine and a cosine per particle.
inline Eigen::Quaterniond rotation_quaternion(const Eigen::Vector3d& w, double h) {
  const double t = w.norm() * h, t2 = t * t;
  double c, s_over_t;   // cos(t/2) and sin(t/2) / t
  if (t < 1e-2) {
    c = 1 - t2 * (1.0 / 8) + t2 * t2 * (1.0 / 384);
    s_over_t = 0.5 - t2 * (1.0 / 48) + t2 * t2 * (1.0 / 3840);
  } else {
    c = std::cos(0.5 * t);
    s_over_t = std::sin(0.5 * t) / t;
  }
  const Eigen::Vector3d v = (s_over_t * h) * w;
  return Eigen::Quaterniond(c, v.x(), v.y(), v.z());
}

// Rotate = false skips every angular array: a scene without torques and without initial spin
// never reads or writes them (half the memory traffic of the step).
template <int D, bool Rotate>
void kick_drift_predict(Particles<D>& P, double h, int threads) {
  const std::size_t N = P.size();
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::size_t i = 0; i < N; ++i) {
    P.velocity[i] += 0.5 * h * P.accel[i];
    P.position[i] += h * P.velocity[i];
    P.velocity_predicted[i] = P.velocity[i] + 0.5 * h * (1.75 * P.accel[i] - 0.75 * P.accel_prev[i]);
    if constexpr (!Rotate) continue;
    P.angular_velocity[i] += 0.5 * h * P.angular_accel[i];
    P.angular_velocity_predicted[i] =
        P.angular_velocity[i] + 0.5 * h * (1.75 * P.angular_accel[i] - 0.75 * P.angular_accel_prev[i]);
    if constexpr (D == 3) {
      auto& q = P.orientation[i];
      q = rotation_quaternion(P.angular_velocity[i], h) * q;
      q.coeffs() *= 1.5 - 0.5 * q.squaredNorm();   // one Newton step back to unit length (drift is O(eps))
    } else {
      P.orientation[i] += h * P.angular_velocity[i][0];
    }
  }
}

// Second half kick from the new forces. Returns the sum of all velocities' components, a cheap
// witness: it is finite exactly when every velocity is.
template <int D, bool Rotate>
double finish_kick(Particles<D>& P, double h, int threads) {
  const std::size_t N = P.size();
  double witness = 0;
#pragma omp parallel for num_threads(threads) schedule(static) reduction(+ : witness)
  for (std::size_t i = 0; i < N; ++i) {
    P.accel_prev[i] = P.accel[i];
    P.accel[i] = P.inv_mass[i] * P.force[i];
    P.velocity[i] += 0.5 * h * P.accel[i];
    witness += P.velocity[i].sum() + P.position[i].sum();
    if constexpr (!Rotate) continue;
    P.angular_accel_prev[i] = P.angular_accel[i];
    P.angular_accel[i] = P.inv_inertia[i] * P.torque[i];
    P.angular_velocity[i] += 0.5 * h * P.angular_accel[i];
    witness += P.angular_velocity[i].sum();
  }
  return witness;
}

}  // namespace grains
