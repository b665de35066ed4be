// Elementary rotations, templated on the scalar (double, or ceres::Jet for automatic derivatives).
// Passive throughout: R_b_from_a maps coordinates, v_b = R_b_from_a · v_a, and Rx(a) is the frame
// rotated by the angle a [rad] about its own x axis. Composition reads right to left, from the
// outer frame inwards: R_c_from_a = R_c_from_b · R_b_from_a.
// The small templates of core/physics are declared inline: they run per sensor sample, and GCC at
// -O2 otherwise may leave them out of line (measured: the lever arm cost twice as much).
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "stend/physics/units.hpp"

namespace stend::physics {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;

// Frame rotated by `a` [rad] about its x / y / z axis: coordinates in the new frame.
template <typename T>
inline Mat3<T> Rx(const T& a) {
  using std::cos;
  using std::sin;
  const T c = cos(a), s = sin(a);
  Mat3<T> R;
  R << T(1), T(0), T(0), T(0), c, s, T(0), -s, c;
  return R;
}
template <typename T>
inline Mat3<T> Ry(const T& a) {
  using std::cos;
  using std::sin;
  const T c = cos(a), s = sin(a);
  Mat3<T> R;
  R << c, T(0), -s, T(0), T(1), T(0), s, T(0), c;
  return R;
}
template <typename T>
inline Mat3<T> Rz(const T& a) {
  using std::cos;
  using std::sin;
  const T c = cos(a), s = sin(a);
  Mat3<T> R;
  R << c, s, T(0), -s, c, T(0), T(0), T(0), T(1);
  return R;
}

// Mounting rotation from roll-pitch-yaw in degrees (applied z-y-x: R = Rx(roll)·Ry(pitch)·Rz(yaw)).
inline Eigen::Matrix3d from_rpy_deg(double roll, double pitch, double yaw) {
  return Rx(roll * kDegToRad) * Ry(pitch * kDegToRad) * Rz(yaw * kDegToRad);
}

}  // namespace stend::physics
