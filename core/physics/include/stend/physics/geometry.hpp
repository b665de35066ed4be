// Rotations, the paper's turntable direction-cosine chain, and local gravity.
// Passive rotation matrices throughout: v_b = R_b_from_a · v_a. Angles in radians unless _deg.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace stend::physics {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kEarthRateRadps = 7.2921150e-5;  // WGS-84 ω_ie

// Frame rotated by `a` about its x / y / z axis: coordinates in the new frame.
inline Eigen::Matrix3d Rx(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, c, s, 0, -s, c;
  return R;
}
inline Eigen::Matrix3d Ry(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d R;
  R << c, 0, -s, 0, 1, 0, s, 0, c;
  return R;
}
inline Eigen::Matrix3d Rz(double a) {
  const double c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d R;
  R << c, s, 0, -s, c, 0, 0, 0, 1;
  return R;
}

// The paper's Table 1: table frame xyz from base ξ0 η0 ζ for tilt h of the rotation axis and
// rotation angle δ: C = Ry(δ)·Rx(h). Gravity (specific force +g·ζ at rest) projects to
//   f = C·[0,0,g] = g·[−sin δ cos h, sin h, cos δ cos h]   (eq. (3) with g pointing down negated).
inline Eigen::Matrix3d paper_table(double tilt_h, double rotation_delta) {
  return Ry(rotation_delta) * Rx(tilt_h);
}

// Mounting rotation from roll-pitch-yaw in degrees (applied z-y-x: R = Rx(roll)·Ry(pitch)·Rz(yaw)).
inline Eigen::Matrix3d from_rpy_deg(double roll, double pitch, double yaw) {
  return Rx(roll * kDegToRad) * Ry(pitch * kDegToRad) * Rz(yaw * kDegToRad);
}

// WGS-84 normal gravity (Somigliana) at geodetic latitude, with the second-order free-air
// height correction. Returns m/s^2. Accurate to ~1e-6 m/s^2 against the full formula near
// the surface; local anomalies (up to ~1e-3 m/s^2) are not modelled — give `value_mps2` then.
inline double normal_gravity(double latitude_deg, double height_m) {
  constexpr double a = 6378137.0, f = 1.0 / 298.257223563, m = 0.00344978650684;
  constexpr double ge = 9.7803253359, k = 0.00193185265241, e2 = 0.00669437999013;
  const double s2 = std::pow(std::sin(latitude_deg * kDegToRad), 2);
  const double g0 = ge * (1.0 + k * s2) / std::sqrt(1.0 - e2 * s2);
  return g0 * (1.0 - 2.0 / a * (1.0 + f + m - 2.0 * f * s2) * height_m +
               3.0 / (a * a) * height_m * height_m);
}

// Earth rotation in the local frame (x east, y north, z up, as the bench base when its heading
// is 0), rad/s.
inline Eigen::Vector3d earth_rate_local(double latitude_deg) {
  const double phi = latitude_deg * kDegToRad;
  return {0.0, kEarthRateRadps * std::cos(phi), kEarthRateRadps * std::sin(phi)};
}

}  // namespace stend::physics
