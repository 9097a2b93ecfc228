// Velocity Verlet for translation and rotation, split around the force evaluation.
// Between the two halves, `velocity` holds v(t + h/2) (which moved the positions and feeds the
// tangential springs) and `velocity_predicted` a third-order estimate of v(t + h) for the dashpots:
//   v(t+h) ~ v(t+h/2) + h/2 (7/4 a_n - 3/4 a_{n-1}).
#pragma once
#include <cmath>
#include <utility>
#include <vector>

#include <omp.h>

#include "core/particles.hpp"

namespace grains {

// The rotation by angle |w| h about w, as a quaternion. Per-step angles are tiny, where the series
// in t^2 (exact to double precision below t = 1e-2) needs neither a square root nor a sine and cosine.
inline Eigen::Quaterniond rotation_quaternion(const Eigen::Vector3d& w, double h) {
  const double t2 = w.squaredNorm() * (h * h);
  double c, s_over_t;   // cos(t/2) and sin(t/2) / t
  if (t2 < 1e-4) {
    c = 1 - t2 * (1.0 / 8) + t2 * t2 * (1.0 / 384);
    s_over_t = 0.5 - t2 * (1.0 / 48) + t2 * t2 * (1.0 / 3840);
  } else {
    const double t = std::sqrt(t2);
    c = std::cos(0.5 * t);
    s_over_t = std::sin(0.5 * t) / t;
  }
  const Eigen::Vector3d v = (s_over_t * h) * w;
  return Eigen::Quaterniond(c, v.x(), v.y(), v.z());
}

namespace integrator_detail {

// Thread t's share of n items: contiguous, in thread order.
inline std::pair<std::size_t, std::size_t> share(std::size_t n, int t, int threads) {
  return {n * std::size_t(t) / std::size_t(threads), n * std::size_t(t + 1) / std::size_t(threads)};
}

// An array of fixed-size vectors as the plain doubles it holds, so that the kernels below run over
// unaliased flat arrays (the compiler then keeps everything in registers and vectorises).
template <class V> double* flat(std::vector<V>& v) {
  static_assert(sizeof(V) == V::SizeAtCompileTime * sizeof(double));
  return reinterpret_cast<double*>(v.data());
}
template <class V> const double* flat(const std::vector<V>& v) {
  static_assert(sizeof(V) == V::SizeAtCompileTime * sizeof(double));
  return reinterpret_cast<const double*>(v.data());
}

// First half over n components: v += h/2 a; x += h v; vp = v + h/2 (7/4 a - 3/4 a_prev).
// Returns the sum of the new x (only its finiteness matters, so the order of the sum is free).
inline double drift(std::size_t n, double h, double* __restrict x, double* __restrict v, double* __restrict vp,
                    const double* __restrict a, const double* __restrict a_prev) {
  double witness = 0;
#pragma omp simd reduction(+ : witness)
  for (std::size_t k = 0; k < n; ++k) {
    v[k] += 0.5 * h * a[k];
    x[k] += h * v[k];
    vp[k] = v[k] + 0.5 * h * (1.75 * a[k] - 0.75 * a_prev[k]);
    witness += x[k];
  }
  return witness;
}

// The rotational first half in 3D over n particles: w kicked and predicted as v above, then the
// orientation q (stored x, y, z, w) turned by the rotation of angle |w| h about w, written out as
// a Hamilton product, and brought back to unit length by one Newton step (the drift is O(eps)).
inline void spin_drift(std::size_t n, double h, double* __restrict w, double* __restrict wp, const double* __restrict alpha,
                       const double* __restrict alpha_prev, double* __restrict q) {
  for (std::size_t i = 0; i < n; ++i) {
    double* const wi = w + 3 * i;
    for (int c = 0; c < 3; ++c) {
      const std::size_t k = 3 * i + c;
      wi[c] += 0.5 * h * alpha[k];
      wp[k] = wi[c] + 0.5 * h * (1.75 * alpha[k] - 0.75 * alpha_prev[k]);
    }
    const Eigen::Quaterniond r = rotation_quaternion(Eigen::Vector3d(wi[0], wi[1], wi[2]), h);
    const double rw = r.w(), rx = r.x(), ry = r.y(), rz = r.z();
    double* const qi = q + 4 * i;
    const double qx = qi[0], qy = qi[1], qz = qi[2], qw = qi[3];
    const double nx = rw * qx + qw * rx + (ry * qz - rz * qy);
    const double ny = rw * qy + qw * ry + (rz * qx - rx * qz);
    const double nz = rw * qz + qw * rz + (rx * qy - ry * qx);
    const double nw = rw * qw - (rx * qx + ry * qy + rz * qz);
    const double unit = 1.5 - 0.5 * (nx * nx + ny * ny + nz * nz + nw * nw);
    qi[0] = nx * unit, qi[1] = ny * unit, qi[2] = nz * unit, qi[3] = nw * unit;
  }
}

// Second half over n particles of C components: a = f / m; v += h/2 a. Returns the sum of the new v.
template <int C>
double kick(std::size_t n, double h, const double* __restrict inverse_mass, const double* __restrict f,
            double* __restrict a, double* __restrict v) {
  double witness = 0;
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < C; ++c) {
      const std::size_t k = i * C + c;
      a[k] = inverse_mass[i] * f[k];
      v[k] += 0.5 * h * a[k];
      witness += v[k];
    }
  return witness;
}

}  // namespace integrator_detail

// Rotate = false skips every angular array: a scene without torques and without initial spin
// never reads or writes them (half the memory traffic of the step). Both halves are memory-bound:
// each array is read or written once. Returns the sum of the new positions' components, a cheap
// witness: it is finite exactly when every position is.
template <int D, bool Rotate>
double kick_drift_predict(Particles<D>& P, double h, int threads) {
  using namespace integrator_detail;
  const std::size_t N = P.size();
  double witness = 0;
#pragma omp parallel num_threads(threads) reduction(+ : witness)
  {
    const auto [b, e] = share(N, omp_get_thread_num(), omp_get_num_threads());
    witness += drift(D * (e - b), h, flat(P.position) + D * b, flat(P.velocity) + D * b, flat(P.velocity_predicted) + D * b,
                     flat(P.accel) + D * b, flat(P.accel_prev) + D * b);
    if constexpr (Rotate && D == 3) {
      static_assert(sizeof(Eigen::Quaterniond) == 4 * sizeof(double));
      spin_drift(e - b, h, flat(P.angular_velocity) + 3 * b, flat(P.angular_velocity_predicted) + 3 * b,
                 flat(P.angular_accel) + 3 * b, flat(P.angular_accel_prev) + 3 * b,
                 reinterpret_cast<double*>(P.orientation.data()) + 4 * b);
    } else if constexpr (Rotate) {   // 2D: the angle simply advances
      for (std::size_t i = b; i < e; ++i) {
        P.angular_velocity[i] += 0.5 * h * P.angular_accel[i];
        P.angular_velocity_predicted[i] =
            P.angular_velocity[i] + 0.5 * h * (1.75 * P.angular_accel[i] - 0.75 * P.angular_accel_prev[i]);
        P.orientation[i] += h * P.angular_velocity[i][0];
      }
    }
  }
  return witness;
}

// Second half kick from the new forces (a_n becomes a_{n-1} by swapping the arrays, not copying).
// Returns the sum of all velocities' components: finite exactly when every velocity is.
template <int D, bool Rotate>
double finish_kick(Particles<D>& P, double h, int threads) {
  using namespace integrator_detail;
  const std::size_t N = P.size();
  constexpr int S = Spin<D>::SizeAtCompileTime;
  double witness = 0;
  P.accel.swap(P.accel_prev);
  if constexpr (Rotate) P.angular_accel.swap(P.angular_accel_prev);
#pragma omp parallel num_threads(threads) reduction(+ : witness)
  {
    const auto [b, e] = share(N, omp_get_thread_num(), omp_get_num_threads());
    witness += kick<D>(e - b, h, P.inv_mass.data() + b, flat(P.force) + D * b, flat(P.accel) + D * b, flat(P.velocity) + D * b);
    if constexpr (Rotate)
      witness += kick<S>(e - b, h, P.inv_inertia.data() + b, flat(P.torque) + S * b, flat(P.angular_accel) + S * b,
                         flat(P.angular_velocity) + S * b);
  }
  return witness;
}

}  // namespace grains
