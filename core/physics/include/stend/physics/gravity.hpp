// Local gravity and Earth rotation, and the specific force gravity produces in a frame.
// Local frame: x east, y north, z up (the bench base when level and its heading is 0).
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "stend/physics/rotations.hpp"

namespace stend::physics {

inline constexpr double kEarthRateRadps = 7.2921150e-5;  // WGS-84 ω_ie

// Local gravity a value given by hand must lie in [m/s²]: the Earth's surface spans about
// 9.76 (equator, high ground) to 9.84 (poles); outside, the value is in the wrong unit or wrong.
inline constexpr double kMinPlausibleGravity_mps2 = 9.7;
inline constexpr double kMaxPlausibleGravity_mps2 = 9.9;

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

// Earth rotation in the local frame, rad/s.
inline Eigen::Vector3d earth_rate_local(double latitude_deg) {
  const double phi = latitude_deg * kDegToRad;
  return {0.0, kEarthRateRadps * std::cos(phi), kEarthRateRadps * std::sin(phi)};
}

// Specific force of gravity g [m/s²] seen in a frame R_frame_from_local: at rest an accelerometer
// reads +g along the local up, f = R·[0, 0, g].
template <typename T>
inline Vec3<T> gravity_specific_force(const Mat3<T>& R_frame_from_local, const T& g) {
  return R_frame_from_local.col(2) * g;
}

// A table base tilted from level by small rotations ε_x about its x axis, then ε_y about its y
// axis [rad]: R_base_from_local = Rx(ε_x)·Ry(ε_y). Compose it under a table chain to see gravity
// through the tilted base: f = gravity_specific_force(R_top_from_base · tilted_base(ε_x, ε_y), g).
template <typename T>
inline Mat3<T> tilted_base(const T& tilt_x, const T& tilt_y) {
  return Rx(tilt_x) * Ry(tilt_y);
}

}  // namespace stend::physics
