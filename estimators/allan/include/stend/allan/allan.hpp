// Allan-deviation noise characterization of inertial sensors (library stend_allan): every
// accelerometer and gyroscope axis of a recording analysed, Kalibr's noise parameters, the text
// table and the stend.allan/1 document. The analysis of one channel — the streaming overlapping
// ADEV, its EDF intervals, the noise-model fit (Q N B K R and a Gauss–Markov bias, one verdict per
// coefficient) and the slope read-offs — is stend_noise's (stats/noise, stend/noise/*.hpp), which
// the gap diagnosis shares; its types are named here as allan's too.
//
// Units: for an accelerometer channel in m/s²: N [m/s²/√Hz] (velocity random walk), K [m/s³/√Hz]
// (acceleration random walk), B [m/s²], Q [m/s], R [m/s³]; for a gyroscope in rad/s: N
// [rad/s/√Hz] (angle random walk), K [rad/s²/√Hz] (rate random walk), B [rad/s], Q [rad],
// R [rad/s²]. Kalibr's accelerometer_noise_density / gyroscope_noise_density are N and
// accelerometer_random_walk / gyroscope_random_walk are K.
#pragma once

#include <stend/noise/allan_stream.hpp>
#include <stend/noise/edf.hpp>
#include <stend/noise/noise_model.hpp>
#include <stend/recording/recording.hpp>

#include <array>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

namespace YAML {
class Node;
}

namespace stend::allan {

inline constexpr const char* kEstimatorName = "allan";
inline constexpr const char* kEstimatorVersion = "0.1.0";
inline constexpr const char* kSchema = "stend.allan/1";

// The noise vocabulary of one channel (stend/noise/), under allan's names.
using noise::AllanCurve;
using noise::AllanPoint;
using noise::analyze;
using noise::assign_intervals;
using noise::ChannelInfo;
using noise::ChannelResult;
using noise::Coefficient;
using noise::Conversion;
using noise::datasheet_units;
using noise::fit_noise_model;
using noise::Instrument;
using noise::kFlickerFloor;
using noise::make_curve;
using noise::NoiseModel;
using noise::NoiseType;
using noise::OctaveVariance;
using noise::OverlappingAllanStream;
using noise::Readoff;
using noise::to_string;
using noise::Units;
using noise::units_for;
using noise::Verdict;

// The analysis of every channel (stend/noise/noise_model.hpp: max_m, confidence, edf_from_model,
// slope_tolerance, min_readoff_edf, min_readoff_points, lowpass_hz) and the part of a recording
// to analyse. analyze_recording takes lowpass_hz from the run's experiment.yaml
// (bench.sensor.config.lowpass_hz) when not set here.
struct AllanOptions : noise::AnalysisOptions {
  // Part of a recording to analyse (run time, s); NaN = from the start / to the end.
  double t_begin_s = kNaN;
  double t_end_s = kNaN;

  // Ceres style: false, with "KEY: what is wrong" in *why, when a value is out of range.
  bool IsValid(std::string* why = nullptr) const;
};

// Options from a YAML mapping whose keys are the field names above (max_m, confidence,
// edf_from_model, slope_tolerance, min_readoff_edf, min_readoff_points, t_begin_s, t_end_s,
// lowpass_hz; the keys `deviations` and `tau` are read by deviations_from_yaml); see
// example/allan.yaml. Throws InputError naming file:line:column and the key for unknown keys,
// wrong types and out-of-range values (AllanOptions::IsValid).
AllanOptions options_from_yaml(const YAML::Node& node, const std::string& file = {});
// "file:line:column" of a YAML node for messages ("<yaml>" without a file name).
std::string yaml_location(const std::string& file, const YAML::Node& node);

// Kalibr's IMU noise parameters (imu.yaml). Kalibr takes ONE continuous-time density per sensor
// (noise density = N, random walk = K); the per-axis values are kept beside it (`*_axes`, in the
// JSON and as comments in imu.yaml). The one number is the largest (worst) axis whose coefficient
// is identified; with no axis identified, the largest slope read-off, else the largest upper bound
// (`*_is_upper_bound`) — never a default. `*_identified` is true when all three axes identified it.
struct KalibrParameters {
  double accelerometer_noise_density = kNaN;  // m/s²/√Hz
  double accelerometer_random_walk = kNaN;    // m/s³/√Hz
  double gyroscope_noise_density = kNaN;      // rad/s/√Hz
  double gyroscope_random_walk = kNaN;        // rad/s²/√Hz
  double update_rate = kNaN;                  // Hz
  bool accelerometer_noise_identified = false;
  bool accelerometer_random_walk_identified = false;
  bool gyroscope_noise_identified = false;
  bool gyroscope_random_walk_identified = false;
  bool accelerometer_random_walk_is_upper_bound = false;
  bool gyroscope_random_walk_is_upper_bound = false;
  // Per axis x, y, z (NaN where the axis gives no value) and each axis's verdict.
  std::array<double, 3> accelerometer_noise_density_axes{kNaN, kNaN, kNaN};
  std::array<double, 3> accelerometer_random_walk_axes{kNaN, kNaN, kNaN};
  std::array<double, 3> gyroscope_noise_density_axes{kNaN, kNaN, kNaN};
  std::array<double, 3> gyroscope_random_walk_axes{kNaN, kNaN, kNaN};
  std::array<Verdict, 3> accelerometer_noise_verdict{Verdict::kFailed, Verdict::kFailed, Verdict::kFailed};
  std::array<Verdict, 3> accelerometer_random_walk_verdict{Verdict::kFailed, Verdict::kFailed, Verdict::kFailed};
  std::array<Verdict, 3> gyroscope_noise_verdict{Verdict::kFailed, Verdict::kFailed, Verdict::kFailed};
  std::array<Verdict, 3> gyroscope_random_walk_verdict{Verdict::kFailed, Verdict::kFailed, Verdict::kFailed};
  // Whether the recording had the instrument (a gyro-only or an accelerometer-only log has one):
  // an absent one's lines are left out of the imu.yaml block, never written as numbers.
  bool accelerometer_present = true, gyroscope_present = true;
};

struct AllanReport {
  std::string source;
  double rate_hz = 0.0;
  std::uint64_t samples = 0;
  double t_begin_s = kNaN, t_end_s = kNaN;
  std::vector<ChannelResult> channels;  // ax ay az gx gy gz: those of the instruments present (noise_channels)
  KalibrParameters kalibr;
  std::vector<std::string> warnings;    // gaps, irregular sampling, …
  std::vector<std::string> notes;       // how the record was judged (e.g. still from the gyroscope alone)
  // Why the selected part of the record is no noise record (it moves, or its temperature drifts:
  // stend/processing/stationarity.hpp), naming the stretches and the longest still one; then no
  // channel is analysed. Empty when still.
  std::string not_still;
};

// The channels a noise analysis reads: the axes of the instruments the recording has (ax ay az,
// gx gy gz; stend/recording/instruments.hpp), never an absent instrument's.
std::vector<Channel> noise_channels(const SensorInfo& info);

// All accelerometer and gyroscope axes of a recording (SI values), within options.t_begin_s …
// t_end_s, once that part is found still (else `not_still` says where it moves and no channel is
// analysed). The rate is the header's output rate, or the median sample interval when it is 0.
AllanReport analyze_recording(const Recording& recording, const AllanOptions& options = {});
KalibrParameters kalibr_parameters(const std::vector<ChannelResult>& channels, double rate_hz);
// True when the report has no channel (a record that is not still) or any channel's model fit
// failed (a constant or too short signal): JSON status "failed", and the estimator's fit fails (non-zero exit of `stend fit`).
bool report_failed(const AllanReport& report);

// Text and JSON (the curve, model and channel print themselves: stend/noise/noise_model.hpp).
std::ostream& operator<<(std::ostream& os, const KalibrParameters& k);
std::ostream& operator<<(std::ostream& os, const AllanReport& r);
// The per-axis summary table (one row per channel: N, K, B, Q, R and the read-offs).
void write_summary_table(std::ostream& os, const AllanReport& report);
void write_json(std::ostream& os, const AllanReport& report, int indent = 2);
void write_json(std::ostream& os, const ChannelResult& result, int indent = 2);
// Kalibr imu.yaml noise block (with the identification status as comments).
void write_kalibr_yaml(std::ostream& os, const KalibrParameters& k);

}  // namespace stend::allan
