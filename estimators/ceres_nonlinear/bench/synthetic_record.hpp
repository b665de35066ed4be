// A synthetic multi-position record (accelerometer + gyro) with known truth, for the benchmarks,
// the memory tool and the gyro tests: `positions` static poses joined by smooth single-axis turns.
//
// Each pose is static for static_fraction of its share of the samples, then the sensor turns by
// 60..150° about a random axis (sensor frame) with the rate profile ω(t) = (2φ/T)·sin²(πt/T) — zero
// rate and zero angular acceleration at both ends, so the pose before and after is truly static.
// Readings: y_a = measure(θ_a, f) + N(0, accel_noise²), y_g = measure(θ_g, ω, f) + N(0, gyro_noise²)
// (accelerometer_model() / gyroscope_model(g-sensitivity when θ_g has 21 entries)); no Earth rate.
#pragma once

#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/physics/units.hpp>

#include <cstdint>
#include <utility>
#include <vector>

namespace stend::ceres_nonlinear::synthetic {

struct Spec {
  int positions = 38;
  std::size_t samples = 51000;
  double rate_hz = 100.0;
  double static_fraction = 0.8;
  double accel_noise_mps2 = 0.02;   // per sample
  double gyro_noise_radps = 0.002;  // per sample
  double gravity_mps2 = physics::kStandardGravity;
  std::uint64_t seed = 1;
  std::vector<double> accel_theta = {0.12, -0.08, 0.2, 0.015, -0.02, 0.008, 0.0, 0.0, 0.006, 0.0, -0.005, 0.003};
  std::vector<double> gyro_theta = {0.01, -0.015, 0.02, 0.01, -0.008, 0.012, 0.004, -0.003, 0.005, 0.002, -0.004, 0.006};
};

struct Record {
  Recording recording;
  std::vector<std::pair<std::size_t, std::size_t>> statics;  // sample index ranges, inclusive
};

Record make(const Spec& spec);

}  // namespace stend::ceres_nonlinear::synthetic
