// A small generator of recordings for the turns and earth_rate gyro methods: a procedure of stills,
// known turns and unlabelled moves, run on a gyroscope with PLANTED errors through the vocabulary
// (ErrorModel::measure: bias, scale, cross-axis, optionally g-sensitivity) plus white noise, with
// the segments and the held truth an aligned recording has (stend/recording/truth_columns.hpp):
//   still (kOrientation)  f = R·g_up, w = Ω_e·sin(latitude)·u (0 without a latitude), turn NaN
//   still (kDetected)     f, w, turn NaN
//   turn (kRotation)      turn = stated axis × angle [deg], f, w NaN; spans from the last sample of
//                         the still before to the first of the still after
//   move                  no segment, no truth
// The sensor frame turns as in bench/synthetic_record.hpp: a turn by φ about sensor axis a maps
// R_sensor_from_local to Rot(−φ, a)·R, with the rate profile ω(t) = a·(2φ/T)·sin²(πt/T). A known
// turn may be made off its stated angle and axis by turn_error_deg (1σ, angle and axis direction).
#pragma once

#include <stend/recording/recording.hpp>

#include <cstdint>
#include <limits>
#include <vector>

namespace stend::ceres_nonlinear::turn_record {

struct Spec {
  std::vector<double> gyro_theta;  // 12 or 21 entries, gyroscope_model()'s order
  double rate_hz = 100.0;
  double gyro_noise_radps = 0.002;  // white, per sample
  double accel_noise_mps2 = 0.02;   // white, per sample (the accelerometer has no other error)
  double gravity_mps2 = 9.80665;
  double turn_error_deg = 0.0;  // 1σ of a known turn's actual angle and axis about the stated ones
  double latitude_deg = std::numeric_limits<double>::quiet_NaN();  // NaN: no Earth rate
  std::uint64_t seed = 1;
};

struct Step {
  enum class Kind { kStill, kDetectedStill, kTurn, kMove };
  Kind kind = Kind::kStill;
  int axis = 0;            // sensor axis of a turn or move (0 x, 1 y, 2 z)
  double angle_deg = 0.0;  // of a turn or move
  double seconds = 10.0;
};

// Six faces (z, y, x up and down) with a 360° turn about each vertical axis between two stills:
// +360 about z, −360 about y, +360 about x (without the x turn when `turn_x` is false); the still
// after the z turn is a detected one.
std::vector<Step> ferraris_steps(bool turn_x = true);
// The six faces (z, y, x up and down), `seconds` each, joined by moves; no turn.
std::vector<Step> six_face_steps(double seconds);
// Still with `axis` up, a 180° move, still with it down; `seconds` each.
std::vector<Step> up_down_steps(int axis, double seconds);

Recording make(const Spec& spec, const std::vector<Step>& steps);

}  // namespace stend::ceres_nonlinear::turn_record
