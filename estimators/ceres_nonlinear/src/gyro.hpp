// Internal to ceres_nonlinear: what the gyroscope procedures share — the parameters
// (gyro_rate_table.cpp), and the jointly whitened observations of the turns and the rate table
// with stated sigmas, their a-priori covariances (gyro_observations.cpp).
#pragma once

#include "solver.hpp"

#include <Eigen/Core>

namespace stend::ceres_nonlinear::detail {

// r.parameters for every parameter of the gyro model, all estimated.
void init_gyro_parameters(CalibrationResult& r);

// One observation of the gyro model: a mean reading ȳ against measure(θ, stimulus) (a still mean,
// a turn in mean form, a rate-table interval).
struct GyroObservation {
  model::Stimulus<double> stimulus;                   // input: the true mean rate [rad/s]; specific force [m/s^2]
  Eigen::Vector3d reading = Eigen::Vector3d::Zero();  // the mean reading ȳ [rad/s]
};

// All observations in one residual block on the free parameters x (free_index: their places in the
// model's parameter vector; the others 0), whitened jointly by their 3n × 3n a-priori covariance
// (the observations' own 3 × 3 blocks on the diagonal, and what they share off it): W·d stacked,
// W = L⁻¹ (C = L·Lᵀ), d_k = measure(θ, stimulus_k) − ȳ_k, so that its covariance is the identity.
// No robust loss is applied (it would act on the block's sum: joint_loss_note says so). Returns
// the number of residuals (3n).
int add_joint_gyro_observations(const std::vector<GyroObservation>& observations, const Eigen::MatrixXd& covariance,
                                const model::ErrorModel& m, const std::vector<int>& free_index,
                                const CalibrationOptions& o, ceres::Problem& problem, std::vector<double>& x);

// The note a jointly whitened fit adds when the options ask for a robust loss ("" for none).
std::string joint_loss_note(const CalibrationOptions& o);

// The covariance an unmodelled g-sensitivity G (each G_ij ~ N(0, σ_G²) [(rad/s)/(m/s²)]) adds to
// readings at the specific forces f_k: block (k, l) = σ_G²·(f_k·f_l)·I (3n × 3n; a NaN f counts as 0).
Eigen::MatrixXd g_sensitivity_covariance(const std::vector<Eigen::Vector3d>& f, double sigma_radps_per_mps2);

// The per-sample white noise of each gyro axis as the means see it [rad/s]: the RMS of the stills'
// sample standard deviations, at least one quantization step / √12 (quantization_radps: 0 when
// unknown), times the stills' noise_correlation_factor (a low-pass filtered sensor's means scatter
// more than its sample spread says).
Eigen::Vector3d pooled_gyro_noise(const std::vector<processing::StaticPoint>& stills, double quantization_radps);

// The covariance of the Earth rate a still's truth leaves out [(rad/s)²]: `applied` is its stated
// rate (the w columns), `f` its specific force. A stated rate of magnitude Ω_v > 0 is the Earth
// rate's vertical part (an aligned log: the heading is unknown), so the horizontal part, of magnitude
// Ω_h = √(Ω_e² − Ω_v²), adds Ω_h² on each horizontal axis (0 when the whole Earth rate is stated, as
// on a bench). Not Ω_h²/2, the variance of a random heading: a hand keeps the heading from one face
// to the next, so two stills may see the same horizontal rate with opposite signs, which doubles the
// variance of their difference. No stated rate (or 0: the latitude unknown) adds Ω_e² on every axis.
Eigen::Matrix3d earth_rate_covariance(const Eigen::Vector3d& applied, const Eigen::Vector3d& f);
// Its factor B (B·Bᵀ = earth_rate_covariance): Ω_h·(I − u·uᵀ), or Ω_e·I.
Eigen::Matrix3d earth_rate_factor(const Eigen::Vector3d& applied, const Eigen::Vector3d& f);

// The joint covariance of the Earth rate the stills' truth leaves out (3n × 3n): stills whose
// gravity directions lie within 30° of each other are taken as one orientation at one heading (the
// same horizontal rate: a turn returns the sensor where it was, a face is held again), so their
// blocks are B_k·B_lᵀ — averaging such stills does not average it away; other stills independent.
Eigen::MatrixXd stills_earth_rate_covariance(const std::vector<processing::StaticPoint>& stills);

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
