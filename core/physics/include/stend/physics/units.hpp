// Units, one definition each. SI inside (m/s², rad, rad/s); a constant below is the SI value of
// one of its unit: multiply a value given in the unit to get SI, divide an SI value to show it.
//   accel_range_g * kStandardGravity   → m/s²        residual_mps2 / kMilliG → mg
//   rate_dps * kDegPerSecond           → rad/s       bias_radps / kDegPerHour → deg/h
// They live in core/physics (not core/model) because physics itself converts degrees (latitudes,
// mounting angles) and core/model depends on core/physics, never the other way round.
#pragma once

#include <numbers>

namespace stend::physics {

// Standard gravity g0 [m/s²] (CGPM 1901): the value of the unit "g" in full-scale ranges, noise
// densities (µg/√Hz) and vibration amplitudes. Not the local gravity of a bench — that is
// normal_gravity() in gravity.hpp or the experiment's value.
inline constexpr double kStandardGravity = 9.80665;
inline constexpr double kMilliG = 1e-3 * kStandardGravity;  // m/s² per mg
inline constexpr double kMicroG = 1e-6 * kStandardGravity;  // m/s² per µg

inline constexpr double kDegToRad = std::numbers::pi / 180.0;  // rad per deg
inline constexpr double kRadToDeg = 180.0 / std::numbers::pi;  // deg per rad
inline constexpr double kDegPerSecond = kDegToRad;             // rad/s per deg/s
inline constexpr double kDegPerHour = kDegToRad / 3600.0;      // rad/s per deg/h

}  // namespace stend::physics
