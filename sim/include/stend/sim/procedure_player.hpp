// The procedure player: what a person (or a rate table) does to a sensor while another tool logs
// it, played on the simulated sensor — the twin of a log recorded elsewhere. Given an experiment
// whose procedure has observed steps (faces, turns, rate_legs, still; stend/core/experiment.hpp —
// table steps first turned into them by core's as_observed_procedure) and a sensor with planted
// errors (SimImuConfig: the error-model vocabulary's terms and the noise processes), it plays:
//
//   faces      a hand move (1–2 s, minimum jerk along the shortest rotation) to each face, the face
//              placed within placement_sigma_deg of the stated one, held for record_s (or hold_s);
//              a face repeated in a row is the same face a quarter turn about the vertical later;
//   still      a hand move to a random orientation, held (count: all plays stills_for_all);
//   turns      a still, then each turn with a hand's rate profile (accelerate, brake) about the
//              stated axis off by turn_axis_sigma_deg, by the stated angle off by
//              turn_angle_sigma_deg, with a small wobble off the axis that starts and ends at zero;
//              a still after each; `direction: either` turns either way at random;
//   rate_legs  the sensor mounted on a level table with the stated `up` (default the axis) up, off
//              by placement_sigma_deg; each leg a still, a ramp up, the rate held for record_s (or
//              hold_s), a ramp down;
//   record     a hold (a bench experiment's record step: a still at an unstated orientation).
//
// The truth it samples is exact physics at each sample instant: the orientation of the sensor
// frame in the local level frame (ENU, at a random heading), the specific force g·up (no
// translation), the angular rate from the orientation's derivative plus the Earth rate at the
// site's latitude (when the experiment states it). The samples come from stend::sim::SimImu fed
// with that truth: the planted errors through ErrorModel::measure, the noise processes, the output
// stage (saturation, quantization: counts and SI). Nothing here writes an error term's formula.
#pragma once

#include <stend/core/experiment.hpp>
#include <stend/sim/imu.hpp>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace stend::sim {

// How the person (and the table) moves; every default written once, here.
struct HandOptions {
  double hold_s = 5.0;                // a face or still held when its step states no record_s [s]
  double hold_factor = 1.2;           // a stated record_s is held this many times (±10 %) [1]
  double move_min_s = 1.0;            // a hand move takes move_min_s + angle/180° · (move_max_s − move_min_s) [s]
  double move_max_s = 2.0;
  double placement_sigma_deg = 0.5;   // tilt of each placement (face, still, table mount) about each horizontal axis
                                      // [deg, 1σ]: about 0.7° in all, as imucal's hand-placed session shows
  double heading_sigma_deg = 5.0;     // heading of a placement about the vertical [deg, 1σ]
  double tremor_deg = 0.0;            // hand tremor while holding (0: the sensor rests on a table) [deg, amplitude]
  double turn_min_s = 3.0;            // a hand turn lasts turn_min_s … turn_max_s (uniform) [s]
  double turn_max_s = 4.0;
  double turn_angle_sigma_deg = 0.5;  // a hand turn's angle off the stated one [deg, 1σ]
  double turn_axis_sigma_deg = 0.5;   // its axis off the stated one, about each perpendicular [deg, 1σ]
  double wobble_deg = 1.0;            // off-axis wobble during a turn [deg, amplitude]
  double table_accel_dps2 = 50.0;     // a rate table's acceleration on its ramps [deg/s²]
  int stills_for_all = 20;            // stills played for `still: {count: all}`

  bool IsValid(std::string* error = nullptr) const;
};

struct PlayerOptions {
  double rate_hz = 100.0;   // the sensor's output rate (replaces the SimImuConfig's) [Hz]
  std::uint64_t seed = 1;   // the motion's randomness and the sensor's noise
  HandOptions hand;

  bool IsValid(std::string* error = nullptr) const;
};

// One step as it was played: what the person actually did.
struct PlayedStep {
  std::string label;            // the procedure step's label, with the face, still, turn or leg number
  double t_start_s = 0.0, t_end_s = 0.0;
  Eigen::Vector3d up = Eigen::Vector3d::Zero();        // held stills: the sensor direction actually up
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();  // turns: the net rotation vector actually turned
  double rate_dps = 0.0;                                // legs: the table rate held
};

// The planted truth: the sensor's deterministic errors as the estimators name them (the flat list
// of ceres.json: accel_bias_x …, gyro_cross_zy, gyro_gsens_xx …; SI) and its noise densities.
struct PlantedTruth {
  std::map<std::string, double> parameters;
  double accel_noise_density = 0.0;  // m/s²/√Hz
  double gyro_noise_density = 0.0;   // rad/s/√Hz

  // The same sensor in the accelerometer's frame convention of a fit with unknown orientations
  // (cross_xy = cross_xz = cross_yz = 0: the x sensing axis defines the frame, y lies in its x-y
  // plane): the accelerometer's matrix A = I + diag(scale) + M written as L·R (L lower triangular
  // with a positive diagonal, R a rotation), and the gyro's A and G carried into the rotated frame
  // (A·Rᵀ, G·Rᵀ) — what such a fit can recover.
  PlantedTruth in_accel_frame_convention() const;
};

struct Played {
  std::vector<ImuSample> samples;  // t = k / rate, k = 1, 2, …
  SensorInfo info;                 // rate, ranges, LSBs
  PlantedTruth truth;
  std::vector<PlayedStep> steps;
  double gravity_mps2 = 0.0;       // the site's g the world had
};

// Plays the experiment's procedure on the sensor. Throws InputError for a step it cannot play (a
// table step not turned into faces and legs, a rate leg whose `up` is not along its axis).
Played play_procedure(const Experiment& exp, const SimImuConfig& sensor, const PlayerOptions& options);

// A sensor of the MPU-6050's class with errors drawn from its datasheet's spread (seeded):
// accelerometer bias 30 mg, scale 1 %, cross-axis 0.5 %; gyro bias 1 °/s, scale 1 %, cross-axis
// 0.5 %, g-sensitivity 0.05 (°/s)/g (1σ each); ±2 g and ±500 °/s, 16 bits; the simulator's white
// noise densities (400 µg/√Hz, 0.005 °/s/√Hz), without its bias instability and random walk (they
// move the bias during a session: a fit's bias is the session's, see docs/real-data.md).
SimImuConfig twin_sensor(std::uint64_t seed);

// The deterministic errors of `sensor` as PlantedTruth (the names of ceres.json's flat list).
PlantedTruth planted_truth(const SimImuConfig& sensor);

}  // namespace stend::sim
