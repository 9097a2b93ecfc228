// Small fixed-size vector types shared by the whole engine (D = 2 disks, D = 3 spheres).
#pragma once
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <type_traits>

namespace grains {

template <int D> using Vec = Eigen::Matrix<double, D, 1>;

// Angular quantities: a vector in 3D, a scalar (stored as a 1-vector) in 2D.
template <int D> using Spin = std::conditional_t<D == 3, Eigen::Vector3d, Eigen::Matrix<double, 1, 1>>;

// Orientation: a unit quaternion in 3D, an angle in 2D.
template <int D> using Orientation = std::conditional_t<D == 3, Eigen::Quaterniond, double>;

// omega x r for the dimension at hand (2D: omega is a scalar about the z axis).
template <int D> inline Vec<D> cross(const Spin<D>& w, const Vec<D>& r) {
  if constexpr (D == 3) return w.cross(r);
  else return Vec<2>(-w[0] * r[1], w[0] * r[0]);
}

// r x F: the torque of force F applied at lever arm r.
template <int D> inline Spin<D> torque(const Vec<D>& r, const Vec<D>& f) {
  if constexpr (D == 3) return r.cross(f);
  else return Spin<2>(r[0] * f[1] - r[1] * f[0]);
}

}  // namespace grains
