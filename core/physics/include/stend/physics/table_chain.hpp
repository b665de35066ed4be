// Turntable direction-cosine chains and their kinematics, templated on the scalar. Frames: base =
// the bench below the table (z up when level), top = the table plate. Angles [rad], rates [rad/s],
// angular accelerations [rad/s²]; passive rotations (rotations.hpp).
//
// Three-axis table: azimuth az (outer, about the base z axis), tilt h (middle, about x), rotation
// δ (inner, about y):
//     R_top_from_base = Ry(δ)·Rx(h)·Rz(az)
// With az = 0 it is the paper's Table 1 chain C = Ry(δ)·Rx(h), which a one-axis table whose axis
// was tilted beforehand by h also follows. Gravity's specific force on the plate (+g·ζ at rest):
//     f = C·[0, 0, g] = g·[−sin δ cos h, sin h, cos δ cos h]   (eq. (3) with g pointing down negated).
// The top's angular velocity, each axis's rate carried into the top frame by the joints inside it:
//     ω_top = Ry(δ)·Rx(h)·[0, 0, daz/dt] + Ry(δ)·[dh/dt, 0, 0] + [0, dδ/dt, 0].
#pragma once

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>

#include "stend/physics/rotations.hpp"

namespace stend::physics {

// The paper's chain C = Ry(δ)·Rx(h) for a tilt h fixed beforehand: cos h and sin h are computed
// once, so each rotation δ costs one sine/cosine pair (a one-axis table evaluates it per sample).
template <typename T>
class PaperTable {
 public:
  explicit PaperTable(const T& tilt_h) {
    using std::cos;
    using std::sin;
    ch_ = cos(tilt_h);
    sh_ = sin(tilt_h);
  }
  // R_top_from_base = Ry(δ)·Rx(h), multiplied out.
  Mat3<T> at(const T& rotation_delta) const {
    using std::cos;
    using std::sin;
    const T c = cos(rotation_delta), s = sin(rotation_delta);
    Mat3<T> C;
    C << c, s * sh_, -s * ch_, T(0), ch_, sh_, s, -c * sh_, c * ch_;
    return C;
  }

 private:
  T ch_, sh_;
};

// The paper's Table 1: table frame from base for tilt h of the rotation axis and rotation angle δ.
template <typename T>
inline Mat3<T> paper_table(const T& tilt_h, const T& rotation_delta) {
  return PaperTable<T>(tilt_h).at(rotation_delta);
}

// The three-axis table: R_top_from_base = Ry(δ)·Rx(h)·Rz(az).
template <typename T>
inline Mat3<T> three_axis_table(const T& azimuth, const T& tilt_h, const T& rotation_delta) {
  return paper_table(tilt_h, rotation_delta) * Rz(azimuth);
}

// Table angles (h, δ) [rad] that turn the base's up (0, 0, 1) into the unit vector `up` of the top
// frame, the inverse of f/g above: h = asin(up_y), δ = atan2(−up_x, up_z).
inline std::pair<double, double> paper_table_pointing(const Eigen::Vector3d& up) {
  return {std::asin(std::clamp(up[1], -1.0, 1.0)), std::atan2(-up[0], up[2])};
}

// Attitude, angular velocity and angular acceleration of a table top, top frame.
template <typename T>
struct TableMotion {
  Mat3<T> R_top_from_base;
  Vec3<T> omega_top_radps;   // ω of the top relative to the base
  Vec3<T> alpha_top_radps2;  // dω/dt
};

// Motion of the three-axis table top for angles q = [az, h, δ] [rad], rates q̇ [rad/s] and
// accelerations q̈ [rad/s²]. With C = Ry(δ)·Rx(h) the axes in the top frame are C·e_z (azimuth),
// Ry(δ)·e_x = C·e_x (tilt) and e_y (rotation), so ω = Σ ω_k with ω_k = axis_k·q̇_k, and
//     α = Σ axis_k·q̈_k + ω_az × ω_h + (ω_az + ω_h) × ω_δ
// (seen from the top, an outer axis turns against the rates inside it: d(axis_k)/dt =
// axis_k × Σ_{j inside k} ω_j).
template <typename T>
inline TableMotion<T> three_axis_table_motion(const Vec3<T>& q, const Vec3<T>& q_dot, const Vec3<T>& q_ddot) {
  const Mat3<T> C = paper_table(q[1], q[2]);
  const Vec3<T> axis_az = C.col(2), axis_h = C.col(0), axis_d = Vec3<T>::UnitY();
  const Vec3<T> w_az = axis_az * q_dot[0], w_h = axis_h * q_dot[1], w_d = axis_d * q_dot[2];
  TableMotion<T> m;
  m.R_top_from_base = C * Rz(q[0]);
  m.omega_top_radps = w_az + w_h + w_d;
  m.alpha_top_radps2 = axis_az * q_ddot[0] + axis_h * q_ddot[1] + axis_d * q_ddot[2] + w_az.cross(w_h) +
                       (w_az + w_h).cross(w_d);
  return m;
}

// The paper's one-axis table: rotation δ with rate dδ/dt [rad/s] and acceleration d²δ/dt² [rad/s²]
// about an axis tilted beforehand by h — the three-axis chain with the azimuth at 0 and the tilt
// held.
template <typename T>
inline TableMotion<T> paper_table_motion(const T& tilt_h, const T& rotation_delta, const T& rate, const T& accel = T(0)) {
  return three_axis_table_motion<T>(Vec3<T>(T(0), tilt_h, rotation_delta), Vec3<T>(T(0), T(0), rate),
                                    Vec3<T>(T(0), T(0), accel));
}

}  // namespace stend::physics
