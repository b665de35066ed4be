// Static intervals found in the samples themselves, for recordings whose segments do not say
// where the sensor stood still (hand-held sessions, imported logs): a centred sliding-window
// variance of the accelerometer, thresholded, then gated on the gyro rate with its zero-rate
// offset removed. A recording without an accelerometer (SensorInfo::has_accel false) is judged on
// the gyroscope alone: the window variance is the gyroscope's (the summary says so:
// by_gyroscope); one without a gyroscope has no gate.
//
// Every setting whose value is 0 is chosen from the data (each rule written once, here):
//   window_s        max(kAutoWindowS, kMinWindowSamples samples at the recording's rate)
//   min_duration_s  max(kAutoMinDurationS, 2 windows)
//   init interval   init_duration_s, else the recording's "initialization" segment (an
//                   importer's still start), else none
//   noise variance  the median window variance over the init interval, else the 10th percentile
//                   of the window variance over the recording (valid when ≥ 10 % of it is still)
//   multiplier      scanned over kScanMultipliers (IMU-TK's 2..10 × the still variance); each
//                   candidate set is judged by its count and by the RMS residual [m/s²] of a
//                   quadric (ellipsoid) fitted to the interval means — the surface a perfect
//                   calibration maps onto |a| = g, so motion inside an interval shows as residual.
//                   Of the multipliers keeping the most distinct poses (a loose threshold merges a
//                   pose with the move next to it, which the gyro gate then cuts away; a tight one
//                   splits a pose by noise, which counts once), the least residual wins. When no
//                   multiplier gives ≥ 10 distinct poses determining the quadric (e.g. six
//                   axis-aligned poses): kFallbackMultiplier.
//   gyro bias       the mean gyro reading over the init interval, else the per-axis median over
//                   the stillest samples (window variance ≤ the lowest scanned threshold)
// A sample is still when its window variance is at most the threshold and the window mean of its
// gyro reading, less that bias, is at most max_gyro_radps (a turn at constant rate about the
// vertical leaves the accelerometer still; the end of a move is slow).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "stend/physics/units.hpp"
#include "stend/processing/option_problem.hpp"
#include "stend/recording/recording.hpp"

namespace stend::processing {

inline constexpr double kAutoWindowS = 0.2;        // [s] short: poses of 1 s must survive the window
inline constexpr int kMinWindowSamples = 11;       // IMU-TK's least window
inline constexpr double kAutoMinDurationS = 0.5;   // [s]
inline constexpr std::array<double, 9> kScanMultipliers = {2, 3, 4, 5, 6, 7, 8, 9, 10};
inline constexpr double kFallbackMultiplier = 4.0;
inline constexpr double kSamePoseDeg = 2.0;        // consecutive intervals closer than this: one pose
inline constexpr double kDefaultMaxGyroRadps = 3.0 * physics::kDegPerSecond;  // 3 deg/s

struct StaticDetectorOptions {
  double window_s = 0.0;          // centred sliding window for the variance; 0: from the rate
  double min_duration_s = 0.0;    // shorter still runs are rejected; 0: from the window
  // Sum of the three accelerometer variances over the window [(m/s^2)^2] below which a sample is
  // static. <= 0: threshold_multiplier × the noise variance (see above).
  double variance_threshold = 0.0;
  double threshold_multiplier = 0.0;  // 0: scanned
  double init_duration_s = 0.0;       // the still start [s]; 0: the "initialization" segment, if any
  double trim_s = 0.0;                // dropped at each end of a detected interval
  // > 0: samples whose window-mean gyro reading, less the gyro bias estimated from the still data,
  // exceeds this norm [rad/s] are not still. 0: no gate.
  double max_gyro_radps = kDefaultMaxGyroRadps;

  // The first value out of range (every one >= 0; key as in YAML: variance_threshold_m2ps4,
  // max_gyro_dps); IsValid Ceres style, with "KEY: what is wrong" in *message.
  std::optional<OptionProblem> problem() const;
  bool IsValid(std::string* message = nullptr) const;
};

struct DetectedInterval {
  std::size_t first = 0, last = 0;        // sample indices, inclusive, after trim_s
  double t_start_s = 0.0, t_end_s = 0.0;  // times of samples first and last
  Eigen::Vector3d accel_mean_mps2 = Eigen::Vector3d::Zero();  // plain means of those samples
  Eigen::Vector3d gyro_mean_radps = Eigen::Vector3d::Zero();
};

// Why a still run of samples did not become an interval.
enum class Rejection {
  kTooShort,    // shorter than min_duration_s (after trim_s)
  kGyroRate,    // an accelerometer-still run cut where the gyro rate, bias removed, exceeds the gate
  kSaturated,   // a saturated accelerometer or gyro sample inside
  kGap,         // a still run split at a gap (kGapBefore): counted once per split, never bridged
};
inline constexpr Rejection kAllRejections[] = {Rejection::kTooShort, Rejection::kGyroRate,
                                               Rejection::kSaturated, Rejection::kGap};
const char* rejection_name(Rejection r);  // "too_short" | "gyro_rate" | "saturated" | "gap"

// How the detector chose its settings and what it rejected.
struct DetectionSummary {
  double rate_hz = 0.0;            // mean sample rate of the recording
  double window_s = 0.0, min_duration_s = 0.0;
  double init_duration_s = 0.0;    // the still start used (0: none)
  bool by_gyroscope = false;       // the variances are the gyroscope's [(rad/s)^2]: no accelerometer
  double noise_variance = 0.0;     // [(m/s^2)^2] (by_gyroscope: [(rad/s)^2]), the base the multiplier scales
  std::string noise_source;        // "median over the first 36.5 s" | "10th percentile over the recording" | "given"
  double multiplier = 0.0;         // chosen (0 when the threshold was given)
  std::string multiplier_choice;   // how: "given" | "scanned …" | "fallback …"
  double threshold = 0.0;          // [(m/s^2)^2] (by_gyroscope: [(rad/s)^2])
  struct ScanStep {
    double multiplier = 0.0;
    std::size_t intervals = 0;
    std::size_t poses = 0;          // distinct: consecutive intervals within kSamePoseDeg are one
    double quadric_rms_mps2 = 0.0;  // NaN when the intervals do not determine a quadric
  };
  std::vector<ScanStep> scan;       // empty unless scanned
  Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();
  std::string gyro_bias_source;
  double max_gyro_radps = 0.0;
  std::array<std::size_t, 4> rejected{};  // by Rejection
  std::size_t found = 0;

  std::size_t count(Rejection r) const { return rejected[static_cast<std::size_t>(r)]; }
  std::string print() const;  // a few lines with units
  // What the rules took, for a message: "the detector rejected 4 still run(s): 3 too_short, 1 gap".
  std::string rejections() const;
  bool equals(const DetectionSummary& other, double tol = 1e-12) const;
};

struct Detection {
  std::vector<DetectedInterval> intervals;
  DetectionSummary summary;
};

// Sliding-window variance detector over rec.sample_source() (in time order), read in chunks of
// `chunk_samples`: memory is the window's plus the runs found, not the record's. A sample flagged
// kGapBefore starts a new run. Throws std::invalid_argument when the sample times do not
// increase over the recording.
Detection detect_static(const Recording& rec, const StaticDetectorOptions& options = {},
                        std::size_t chunk_samples = kDefaultChunkSamples);
// detect_static(rec, options).intervals
std::vector<DetectedInterval> detect_static_intervals(const Recording& rec,
                                                      const StaticDetectorOptions& options = {});

}  // namespace stend::processing
