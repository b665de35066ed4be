// Nonlinear (Ceres) calibration of a 3-axis accelerometer from static intervals, plus the gyro bias.
//
// Model: the error-model vocabulary (stend/model/terms.hpp) with the terms bias, scale and
// cross_axis,  y = u + b + diag(s)·u + M·u  (M: off-diagonal cross-axis terms), evaluated only
// through ErrorModel::measure<T> / ErrorModel::correct.
//
// (a) Orientations unknown, only |g| known (IMU-TK / Ferraris style): for every static interval
//     with mean reading ȳ_k the residual is  |u_k(θ)| − g  with u_k the input that the model maps
//     to ȳ_k. A rotation of the sensor frame is unobservable, so three cross-axis terms are held
//     at zero (default: cross_xy, cross_xz, cross_yz — the x sensing axis defines the frame, the y
//     sensing axis lies in its x-y plane): 9 parameters, at least 10 intervals (9 + 1 for noise).
// (b) Orientations known (the table's truth columns f_x_mps2 f_y_mps2 f_z_mps2, or given
//     vectors): residual ȳ_k − measure(θ, f_k), all 12 parameters.
//
// Uncertainty: ceres::Covariance (dense SVD) scaled by σ² = RSS / (n − p); intervals θ̂ ± t·se
// (Student t, n − p degrees of freedom). Identifiability (stend/estimation/identifiability.hpp):
// SVD of the Jacobian at the solution (columns scaled by a nominal size: g for a bias, 1 for a
// dimensionless term); a direction whose singular value is below rank_tolerance·σ_max makes the
// fit fail naming the unidentified combination ("bias_z + 0.98*scale_z"). A converged fit on a
// non-singular Jacobian is always reported; each parameter carries its standard error and a
// verdict against its precision tolerance (`tolerances`). A failed fit (too few intervals, no
// convergence, singular, ceres::Covariance failure) has ok = false, a message, and NaN values:
// never an identity calibration.
#pragma once

#include <stend/estimation/summary.hpp>
#include <stend/model/terms.hpp>
#include <stend/processing/static_points.hpp>
#include <stend/recording/recording.hpp>

#include <Eigen/Core>
#include <Eigen/Dense>
#include <cstddef>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace stend::ceres_nonlinear {

// ---------------------------------------------------------------------------------------------
// Static intervals — from the processing stage (stend/processing/static_points.hpp)

struct StaticInterval {
  std::size_t first = 0, last = 0;  // sample indices, inclusive
  double t_start_s = 0.0, t_end_s = 0.0;
  std::size_t count = 0;
  Eigen::Vector3d accel_mean = Eigen::Vector3d::Zero();  // m/s^2 (the recording's SI values)
  Eigen::Vector3d accel_std = Eigen::Vector3d::Zero();   // per-sample standard deviation
  Eigen::Vector3d gyro_mean = Eigen::Vector3d::Zero();   // rad/s
  Eigen::Vector3d gyro_std = Eigen::Vector3d::Zero();    // per-sample standard deviation
  std::string label;
};

// Mean and spread of samples first..last (inclusive).
StaticInterval make_interval(const Recording& rec, std::size_t first, std::size_t last,
                             std::string label = {});
// A processing point (both instruments extracted) in this estimator's form.
StaticInterval to_interval(const processing::StaticPoint& point);

// How the accelerometer fits find their static intervals unless told otherwise: detected in the
// samples (processing::StaticDetectorOptions), each the plain mean of its samples — no low-pass,
// nothing discarded beyond the detector's trim_s. For the recording's orientation segments set
// intervals = kSegments and extraction.settle_s to the time dropped at each end.
processing::ProcessingOptions default_interval_options();
// The rate table's intervals: the recording's orientation and rate segments, plain means, 0.5 s
// dropped at each end; the interval source and the segment kinds are the method's (stated).
processing::ProcessingOptions rate_table_interval_options();

// The static intervals of a recording as the processing stage finds them (skipped ones left out).
std::vector<StaticInterval> static_intervals(const Recording& rec,
                                             const processing::ProcessingOptions& options = default_interval_options());

// ---------------------------------------------------------------------------------------------
// Calibration

enum class Loss { kNone, kHuber, kCauchy };

struct CalibrationOptions {
  processing::ProcessingOptions processing = default_interval_options();  // the static intervals
  double gravity_mps2 = 0.0;       // 0: the recording header's; both 0 → error, unless:
  bool standard_gravity_fallback = false;  // the recording states no g: standard gravity 9.80665 m/s^2
  Loss loss = Loss::kNone;
  double loss_scale_mps2 = 0.05;   // Huber / Cauchy scale
  double confidence = 0.95;
  int max_iterations = 200;
  double rank_tolerance = 1e-8;    // σ_k / σ_max of the scaled Jacobian
  estimation::PrecisionTolerances tolerances;  // of each parameter's verdict
  // Unknown orientations: cross-axis terms held at zero (names from the vocabulary).
  std::vector<std::string> fixed_cross_axis = {"cross_xy", "cross_xz", "cross_yz"};
  bool estimate_gyro_bias = true;
  // Known orientations: how well the true orientations are known [deg, 1σ tilt]. 0 = exactly
  // (unweighted residuals). > 0: each interval's residual is whitened — along gravity by the noise
  // of the mean (accel_std/√count), across gravity by √(noise² + (g·σ_tilt)²) — so a slightly tilted
  // position spoils the cross-axis terms it informs, not the bias and scale (Ferraris-like).
  double orientation_sigma_deg = 0.0;
  // Known orientations from the table's encoders: table angle zero offsets estimated as extra
  // parameters `table_offset_<axis>` [deg] (true angle = encoder + offset). Axes of a three-axis
  // table chain R = Ry(rotation)·Rx(tilt)·Rz(azimuth) (sim_three_axis_table, the paper's Table 1):
  // "tilt", "rotation". Gravity does not depend on the azimuth, so its offset is never identifiable;
  // the rotation offset turns every position by the same rotation about the plate's y axis, which
  // the cross-axis terms absorb (not identifiable with all 12 terms: the fit says so). The tilt
  // offset is identifiable when the rotation angle varies. Needs the truth columns
  // `<table_fixture>.tilt.meas_deg`, `<table_fixture>.rotation.meas_deg` and the header's mounting.
  std::vector<std::string> table_offsets;
  std::string table_fixture = "table";
};

// A fitted parameter (name, unit, value, standard error, interval, verdict; NaN when not
// identifiable), or one held at zero by construction.
struct Parameter : estimation::ParameterEstimate {
  bool fixed = false;              // held at zero by construction (not estimated)
};

// One move between static intervals (gyro integration): the angle between the gravity direction
// carried over the move by the integrated rate and the one measured after it [rad], raw and
// calibrated; t_end_s: the start of the static interval the move ends in.
struct MoveMismatch {
  double t_end_s = 0.0;
  double before_rad = std::numeric_limits<double>::quiet_NaN();
  double after_rad = std::numeric_limits<double>::quiet_NaN();
};

struct CalibrationResult {
  bool ok = false;
  std::string message;             // why it failed; empty on success
  std::string method;              // "unknown_orientations" | "known_orientations" | "rate_table" | "integration"
  model::ErrorModel model;         // bias, scale, cross_axis (accelerometer); gyro: [+ g_sensitivity]
  std::vector<double> theta;       // model.size() values (NaN when the fit failed)
  std::vector<Parameter> parameters;       // all model parameters (fixed ones marked), then
                                           // table_offset_<axis> [deg] when estimated
  std::vector<Parameter> gyro_parameters;  // gyro_bias_x/y/z when estimated
  std::vector<std::string> not_identifiable;  // parameter names
  std::vector<StaticInterval> intervals;
  // How the intervals were detected, with the rejected candidates by reason (when detected).
  std::optional<processing::DetectionSummary> detection;
  double gravity_mps2 = 0.0;
  int observations = 0, estimated = 0, dof = 0, iterations = 0;
  double sigma = 0.0;              // residual standard deviation [m/s^2] (whitened: 1 = as expected)
  bool whitened = false;           // known orientations with orientation_sigma_deg > 0
  double quantile = 0.0;
  // RMS over the intervals of |ȳ| − g (raw) and |correct(ȳ)| − g (calibrated) [m/s^2].
  // Gyro: RMS of the residual raw (θ = 0) and calibrated [rad/s for rate_table, rad (gravity
  // direction mismatch) for integration].
  double rms_norm_before = 0.0, rms_norm_after = 0.0;
  // Per-axis RMS over the intervals, raw and calibrated, in the instrument unit (m/s^2, rad/s).
  // Known orientations / rate table: correct(ȳ) − truth. Unknown orientations: the part of the
  // calibrated mean along its own direction that is not g, (|c| − g)·ĉ, split on the axes.
  // Integration: the gravity-direction mismatch per axis [rad] (NaN "before" when not computed).
  Eigen::Vector3d rms_axis_before = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d rms_axis_after = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::vector<MoveMismatch> moves;  // gyro integration: per move (empty otherwise)
  // Covariance of the estimated parameters (scaled by σ², order of free_index = their positions
  // in `parameters`); empty when the fit failed.
  Eigen::MatrixXd covariance;
  std::vector<int> free_index;
  double condition_number = 0.0;   // of the scaled Jacobian at the solution (σ_max/σ_min)
  std::string solver_report;

  const Parameter& parameter(const std::string& name) const;  // throws when absent
  // Calibrated specific force for a reading (throws std::logic_error when !ok).
  Eigen::Vector3d correct(const Eigen::Vector3d& y) const;
  std::string report() const;
  std::string to_json() const;
};

// The model these functions fit: bias, scale, cross_axis for an accelerometer (12 parameters).
model::ErrorModel accelerometer_model();

CalibrationResult calibrate_accelerometer_unknown_orientations(const Recording& rec,
                                                               const CalibrationOptions& options = {});
CalibrationResult calibrate_accelerometer_unknown_orientations(
    const std::vector<StaticInterval>& intervals, double gravity_mps2,
    const CalibrationOptions& options = {});

// Truth from the columns f_x_mps2, f_y_mps2, f_z_mps2 (processing's truth mean over each
// interval; intervals without truth are dropped).
CalibrationResult calibrate_accelerometer_known_orientations(const Recording& rec,
                                                             const CalibrationOptions& options = {});
// truth_f[k]: the true specific force of interval k in the sensor frame [m/s^2].
CalibrationResult calibrate_accelerometer_known_orientations(
    const std::vector<StaticInterval>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
    const CalibrationOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Gyroscope
//
// Model: the vocabulary's bias, scale, cross_axis (12 parameters) and, with
// estimate_g_sensitivity, g_sensitivity (9 more: gsens_ij, gyro axis i to specific force f_j):
//   y = ω + b + diag(s)·ω + M·ω + G·f,   evaluated only through ErrorModel::measure<T>.
//
// (a) Rate table (known rates): for every rate segment (and every static orientation segment,
//     ω = the truth's Earth rate) the mean reading ȳ_k against measure(θ, ω_k, f_k) with ω_k, f_k
//     the means of the truth columns w_*_radps, f_*_mps2 inside the interval. Scale and cross-axis
//     need rates about three independent sensor directions; G needs static positions in several
//     gravity directions.
// (b) Integration between static intervals (IMU-TK style; orientations unknown). Two stages:
//     1. bias (and G) from the static intervals: ȳ_k = measure(θ, ω = 0, f_k) with f_k the
//        calibrated specific force (Earth rotation, ≤ 7.3e-5 rad/s, is not modelled and goes into
//        the bias and the residual);
//     2. scale and cross-axis with bias and G held at stage 1: the gravity direction ĝ_k (calibrated
//        accelerometer) carried by the rotation integrated from the corrected gyro readings between
//        intervals k and k+1 must equal ĝ_{k+1}; two residuals per pair (the components normal to
//        ĝ_{k+1}). A rotation about gravity is invisible in one pair, so the motions must turn about
//        varied axes. All six cross-axis terms are identifiable: the accelerometer defines the frame.
//     The stage-2 covariance adds what the upstream estimates pass on (delta method): the
//     accelerometer calibration (through ĝ_k) and the stage-1 bias / G (through the corrected
//     rates), C = C₂ + S·C_up·Sᵀ with S = −(J₂ᵀJ₂)⁻¹J₂ᵀ·∂r/∂z (finite differences).
struct GyroOptions {
  Loss loss = Loss::kNone;
  double loss_scale_radps = 0.01;  // rate table: Huber / Cauchy scale of a residual [rad/s]
  double loss_scale_rad = 0.01;    // integration: of a direction residual [rad]
  double confidence = 0.95;
  int max_iterations = 200;
  double rank_tolerance = 1e-8;
  estimation::PrecisionTolerances tolerances;  // of each parameter's verdict
  bool estimate_g_sensitivity = false;
  processing::ProcessingOptions processing = rate_table_interval_options();  // rate table intervals
};

model::ErrorModel gyroscope_model(bool g_sensitivity);

// Rate table from a recording: segments of kind "rate" and "orientation" (options.processing)
// with the truth columns w_x_radps.. and f_x_mps2..; fails when the recording has none.
CalibrationResult calibrate_gyro_rate_table(const Recording& rec, const GyroOptions& options = {});
// truth_w[k], truth_f[k]: true rate [rad/s] and specific force [m/s^2] of interval k (sensor frame).
CalibrationResult calibrate_gyro_rate_table(const std::vector<StaticInterval>& intervals,
                                            const std::vector<Eigen::Vector3d>& truth_w,
                                            const std::vector<Eigen::Vector3d>& truth_f,
                                            const GyroOptions& options = {});
// Integration between the static intervals of a successful accelerometer calibration (its
// intervals index rec.samples). Fails when `accel` failed or fewer than 7 intervals remain.
CalibrationResult calibrate_gyro_integration(const Recording& rec, const CalibrationResult& accel,
                                             const GyroOptions& options = {});

const char* loss_name(Loss l);
Loss loss_from_name(const std::string& name);  // "none" | "huber" | "cauchy"; throws otherwise

}  // namespace stend::ceres_nonlinear
