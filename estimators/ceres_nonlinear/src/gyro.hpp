// Internal to ceres_nonlinear: what the gyroscope procedures share — the parameters
// (gyro_rate_table.cpp), and the whitened observations of the turns and earth_rate methods
// (gyro_observations.cpp).
#pragma once

#include "solver.hpp"

#include <Eigen/Core>

namespace stend::ceres_nonlinear::detail {

// r.parameters for every parameter of the gyro model, all estimated.
void init_gyro_parameters(CalibrationResult& r);

// One observation of the gyro model, whitened by its a-priori sigma: the residual is
// W·(measure(θ, stimulus) − ȳ) with W a k × 3 matrix [s/rad] (k = 3: a still mean or a turn in mean
// form; k = 1: a projection on the vertical), so that its covariance is the identity.
struct GyroObservation {
  model::Stimulus<double> stimulus;                   // input: the true mean rate [rad/s]; specific force [m/s^2]
  Eigen::Vector3d reading = Eigen::Vector3d::Zero();  // the mean reading ȳ [rad/s]
  Eigen::MatrixXd whitening;                          // k × 3 [s/rad]
};

// Fits the gyro model to the whitened observations, a-priori weighted, on the free parameters
// (free_index: their places in the model's parameter vector; the others 0): r's values,
// covariance and verdicts.
void solve_gyro_observations(const std::vector<GyroObservation>& observations, const std::vector<int>& free_index,
                             const GyroOptions& options, CalibrationResult& r);

// The per-sample white noise of each gyro axis [rad/s]: the RMS of the stills' sample standard
// deviations, at least one quantization step / √12 (quantization_radps: 0 when unknown).
Eigen::Vector3d pooled_gyro_noise(const std::vector<processing::StaticPoint>& stills, double quantization_radps);

// The whitening of a mean of `samples` readings with per-sample noise `noise_radps` per axis:
// diag(√samples / noise) [s/rad].
Eigen::Matrix3d mean_whitening(const Eigen::Vector3d& noise_radps, std::size_t samples);

// The still segments the turns and earth_rate methods read: the recording's segments of the kinds
// orientation and detected, with the settings of options.processing (settle_s = segment_trim_s).
processing::ProcessingOptions still_segment_options(const GyroOptions& options);

// The recording's kRotation segments whole (no settle time, no filter): a turn is integrated over
// all of its samples.
processing::ProcessingOptions turn_segment_options();

// The sample period of a window [s]: its duration over its sample intervals.
double sample_period_s(const processing::StaticPoint& window);

// The mean over a window of the finite values of each of `columns` (truth column indices) [their
// unit]; NaN for a column with no finite value there. Unlike processing's truth mean, a neighbour's
// held row with NaN in a column (the still before a turn has no turn) does not spoil it.
Eigen::Vector3d finite_truth_mean(const Recording& rec, const std::array<int, 3>& columns, double t0_s, double t1_s);

// The truth columns of `names` in the recording, or nullopt when one is missing.
std::optional<std::array<int, 3>> truth_columns(const Recording& rec, const std::array<const char*, 3>& names);

}  // namespace stend::ceres_nonlinear::detail
