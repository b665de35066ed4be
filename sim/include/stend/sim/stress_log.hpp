// A hand-held multi-position log as real ones come, seeded, from the simulated sensor (SimImu: the
// error-model vocabulary forward, its noise and output stage): a still start, then poses of
// pose_s_min..pose_s_max seconds in random (not axis-aligned) orientations joined by hand-like
// moves — a smooth turn about a random axis with a tremor on top —, at a sample rate drawn from
// rates_hz; raw counts stored around an unsigned offset (as a uint16 log around 32768); gyro
// zero-rate offsets up to ±gyro_offset_dps_max; timestamps ideal or rounded to a resolution (as a
// log printing two decimals).
//
// The truth comes back with it: the still sample ranges, the deterministic errors (names of the
// error-model vocabulary), the rate. The accelerometer's cross-axis terms above the diagonal
// (cross_xy, cross_xz, cross_yz) are zero, so the truth is the parametrisation an
// unknown-orientations calibration (x axis = frame x, y axis in the frame's x-y plane) estimates.
#pragma once

#include <stend/sdk.hpp>

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace stend::sim {

enum class StressTimestamps {
  kIdeal,    // t = k / rate
  kRounded,  // rounded to timestamp_resolution_s: consecutive samples may share a timestamp
};

struct StressSpec {
  std::uint64_t seed = 1;
  std::vector<double> rates_hz = {100.0, 200.0, 500.0, 1000.0};  // one is drawn per log
  double init_still_s = 4.0;
  int poses = 24;
  double pose_s_min = 1.0, pose_s_max = 3.0;
  double move_s_min = 0.6, move_s_max = 1.5;
  double move_angle_deg_min = 40.0, move_angle_deg_max = 140.0;
  double tremor_mps2 = 0.3;            // hand tremor during a move (specific force, per axis amplitude)
  double accel_bias_max_mps2 = 0.5;    // |bias| per axis up to this (≈ 50 mg)
  double accel_scale_max = 0.02;
  double accel_cross_max = 0.01;       // cross_yx, cross_zx, cross_zy
  double gyro_offset_dps_max = 5.0;
  std::int32_t count_offset = 32768;   // stored counts = signed counts + this
  StressTimestamps timestamps = StressTimestamps::kIdeal;
  double timestamp_resolution_s = 0.01;
};

struct StressLog {
  double rate_hz = 0.0;
  double gravity_mps2 = 0.0;           // the |g| simulated (standard gravity)
  std::vector<ImuSample> samples;      // counts around count_offset; SI values as an importer gives them
  std::vector<std::pair<std::size_t, std::size_t>> statics;  // true still sample ranges, inclusive
  std::map<std::string, double> accel_truth;  // bias_x [m/s^2], scale_x, cross_yx … (vocabulary names)
  std::map<std::string, double> gyro_truth;   // bias_x [rad/s] …
};

StressLog make_stress_log(const StressSpec& spec);

}  // namespace stend::sim
