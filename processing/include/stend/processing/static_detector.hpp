// Static intervals found in the samples themselves, for recordings whose segments do not say
// where the sensor stood still (hand-held sessions, imported logs): a centred sliding-window
// variance of the accelerometer, thresholded.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "stend/recording.hpp"

namespace stend::processing {

struct StaticDetectorOptions {
  double window_s = 1.0;          // centred sliding window for the variance
  double min_duration_s = 1.0;    // shorter still runs are ignored (hand-held poses are short)
  // Sum of the three accelerometer variances over the window [(m/s^2)^2] below which a sample is
  // static. <= 0: automatic = threshold_multiplier × (that variance over the first
  // init_duration_s when > 0, else its 10th percentile over the whole recording).
  double variance_threshold = 0.0;
  double threshold_multiplier = 6.0;
  double init_duration_s = 0.0;
  double trim_s = 0.0;            // dropped at each end of a detected interval
  // > 0: drop intervals whose mean gyro reading exceeds this norm [rad/s] — a turn about the
  // vertical at constant rate leaves the accelerometer still (used before gyro integration).
  double max_gyro_radps = 0.0;
};

struct DetectedInterval {
  std::size_t first = 0, last = 0;        // sample indices, inclusive, after trim_s
  double t_start_s = 0.0, t_end_s = 0.0;  // times of samples first and last
  Eigen::Vector3d accel_mean_mps2 = Eigen::Vector3d::Zero();  // plain means of those samples
  Eigen::Vector3d gyro_mean_radps = Eigen::Vector3d::Zero();
};

// Sliding-window variance detector over rec.samples (in time order). A sample flagged
// kGapBefore starts a new interval. Throws std::invalid_argument when the sample times do not
// increase over the recording.
std::vector<DetectedInterval> detect_static_intervals(const Recording& rec,
                                                      const StaticDetectorOptions& options = {});

}  // namespace stend::processing
