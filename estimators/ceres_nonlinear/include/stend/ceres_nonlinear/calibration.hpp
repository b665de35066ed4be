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
// convergence, singular, ceres::Covariance failure) has status kFailed, a message, and NaN values:
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
// Static intervals — the processing stage's points (stend/processing/static_points.hpp), both
// instruments extracted: the accelerometer fits use `accel.mean` (and `accel.sample_std`,
// `samples_used`), the gyro fits `gyro.mean`, the integration the samples `first`..`last`.

// Mean and spread of samples first..last (inclusive), both instruments; label as given.
processing::StaticPoint make_interval(const Recording& rec, std::size_t first, std::size_t last,
                                      std::string label = {});

// How the accelerometer fits find their static intervals unless told otherwise: detected in the
// samples (processing::StaticDetectorOptions), each the plain mean of its samples — no low-pass,
// nothing discarded beyond the detector's trim_s. For the recording's orientation segments set
// intervals = kSegments and extraction.settle_s to the time dropped at each end.
processing::ProcessingOptions default_interval_options();
// The rate table's intervals: the recording's orientation and rate segments, plain means, 0.5 s
// dropped at each end; the interval source and the segment kinds are the method's (stated).
processing::ProcessingOptions rate_table_interval_options();

// The static intervals of a recording as the processing stage finds them (skipped ones left out).
std::vector<processing::StaticPoint> static_intervals(const Recording& rec,
                                                      const processing::ProcessingOptions& options = default_interval_options());

// ---------------------------------------------------------------------------------------------
// Calibration

enum class Loss { kNone, kHuber, kCauchy };

// The procedures, one per file (src/accelerometer_unknown.cpp, accelerometer_known.cpp,
// gyro_rate_table.cpp, gyro_integration.cpp, gyro_turns.cpp, gyro_earth_rate.cpp).
enum class Method { kUnknownOrientations, kKnownOrientations, kRateTable, kIntegration, kTurns, kEarthRate };
// "unknown_orientations" | "known_orientations" | "rate_table" | "integration" | "turns" | "earth_rate"
const char* method_name(Method m);

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

  // Every number in range (confidence in (0, 1), iterations ≥ 1, tolerances > 0, scales > 0,
  // known cross-axis and table-offset names, the processing options valid).
  bool IsValid(std::string* error = nullptr) const;
};

// One move between static intervals (gyro integration): the angle between the gravity direction
// carried over the move by the integrated rate and the one measured after it [rad], raw and
// calibrated; t_end_s: the start of the static interval the move ends in.
struct MoveMismatch {
  double t_end_s = 0.0;
  double before_rad = std::numeric_limits<double>::quiet_NaN();
  double after_rad = std::numeric_limits<double>::quiet_NaN();
};

// One known turn (gyroscope: turns): the rotation vector the truth states and the reading
// integrated over the turn's segment, raw and calibrated [rad, sensor frame]; NaN where not computed.
struct TurnCheck {
  std::string label;
  double t_start_s = 0.0, t_end_s = 0.0;
  Eigen::Vector3d stated_rad = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d before_rad = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d after_rad = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
};

// An RMS over the intervals (or moves) of a fit, raw (θ = 0) and calibrated; 0 until the
// procedure computes it (it does not, or it failed before), the calibrated one NaN when it failed.
struct Rms {
  double before = 0.0, after = 0.0;
};
// The same per output axis x, y, z; NaN where not computed.
struct AxisRms {
  Eigen::Vector3d before = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d after = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
};

// The result of one procedure. Every field has one meaning whatever the procedure; those a
// procedure does not compute stay empty or NaN.
struct CalibrationResult {
  estimation::FitStatus status = estimation::FitStatus::kFailed;
  std::string message;             // why it failed; empty on success
  Method method = Method::kUnknownOrientations;
  model::ErrorModel model;         // bias, scale, cross_axis (accelerometer); gyro: [+ g_sensitivity]
  std::vector<double> theta;       // model.size() values (NaN when the fit failed)
  // Every model parameter (those held at 0 by the frame convention marked `held`), then
  // table_offset_<axis> [deg] when estimated (known orientations).
  std::vector<estimation::ParameterEstimate> parameters;
  // Accelerometer fits with estimate_gyro_bias: the gyro bias gyro_bias_x/y/z [rad/s], the mean
  // over the static intervals.
  std::vector<estimation::ParameterEstimate> gyro_bias;
  std::vector<std::string> not_identifiable;  // parameter names
  std::vector<processing::StaticPoint> intervals;
  // How the intervals were detected, with the rejected candidates by reason (when detected).
  std::optional<processing::DetectionSummary> detection;
  // The gravity magnitude [m/s^2]: the one an accelerometer fit used (the integration: its
  // accelerometer's); the rate table: the mean |f| of its truth.
  double gravity_mps2 = 0.0;
  int observations = 0, estimated = 0, dof = 0, iterations = 0;
  // Residual standard deviation of the solve, in sigma_unit(); `whitened`: known orientations with
  // orientation_sigma_deg > 0, turns, earth_rate (1 = as expected; NaN with 0 dof).
  double sigma = 0.0;
  bool whitened = false;
  double quantile = 0.0;           // of the parameters' intervals (Student t; normal with 0 dof)
  // Where the covariance comes from: the a-priori sigmas (turns, earth_rate) and how it is scaled,
  // with the degrees of freedom (e.g. "… 0 dof …: the a-priori covariance").
  std::string uncertainty;
  // Remarks of the procedure, one sentence each: what it left out (a turn with a lost sample, a
  // still without truth) and what it holds and why.
  std::vector<std::string> notes;

  // The checks of the fit (see Rms, AxisRms):
  Rms norm_error_mps2;              // accelerometer fits: |ȳ| − g over the intervals [m/s^2]
  AxisRms norm_error_axis_mps2;     // unknown orientations: (|c| − g)·ĉ of each mean c, per axis [m/s^2]
  AxisRms truth_error_axis;         // known orientations [m/s^2], rate table [rad/s]: ȳ, correct(ȳ) − truth
  Rms rate_error_radps;             // rate table: |ȳ, correct(ȳ) − ω|; earth_rate: u·ȳ, u·correct(ȳ) − Ω_v [rad/s]
  Rms turn_error_rad;               // turns: |v − θ| of the integrated reading v against the stated turn θ [rad]
  AxisRms turn_error_axis_rad;      // turns: v − θ per axis [rad]
  std::vector<TurnCheck> turns;     // turns: per turn
  Rms direction_error_rad;          // integration: |v − ĝ| of the carried gravity direction v after each move
  AxisRms direction_error_axis_rad; // integration: v − ĝ per axis [rad]
  std::vector<MoveMismatch> moves;  // integration: per move

  // Covariance of the estimated parameters (scaled by σ², order of free_index = their positions
  // in `parameters`); empty when the fit failed.
  Eigen::MatrixXd covariance;
  std::vector<int> free_index;
  double condition_number = 0.0;   // of the scaled Jacobian at the solution (σ_max/σ_min)
  std::string solver_report;

  bool ok() const { return status == estimation::FitStatus::kOk; }
  bool is_gyroscope() const { return model.instrument == model::Instrument::kGyroscope; }
  const char* sigma_unit() const;  // "m/s^2", "rad/s", "rad" or "(whitened residuals; 1 = as expected)"
  const estimation::ParameterEstimate& parameter(const std::string& name) const;  // throws when absent
  // Calibrated specific force for a reading (throws std::logic_error when !ok()).
  Eigen::Vector3d correct(const Eigen::Vector3d& y) const;
  std::string report() const;   // src/report.cpp
  std::string to_json() const;  // src/result_writer.cpp
};

// The model these functions fit: bias, scale, cross_axis for an accelerometer (12 parameters).
model::ErrorModel accelerometer_model();

CalibrationResult calibrate_accelerometer_unknown_orientations(const Recording& rec,
                                                               const CalibrationOptions& options = {});
CalibrationResult calibrate_accelerometer_unknown_orientations(
    const std::vector<processing::StaticPoint>& intervals, double gravity_mps2,
    const CalibrationOptions& options = {});

// The unknown-orientations fit judged on intervals it was not fitted to (leave one out): each
// interval left out in turn, the parameters fitted on the others (as few intervals as parameters
// will do: a prediction needs no residual), and |correct(ȳ_k)| − g of the one left out [m/s^2].
// The fair figure of a fit whose own |a| − g is (nearly) zero by construction.
struct HeldOutNormError {
  std::vector<double> error_mps2;  // per interval; NaN where the fit without it failed
  double rms_mps2 = std::numeric_limits<double>::quiet_NaN();  // over the finite ones
  int predicted = 0;                                            // how many are finite
};
HeldOutNormError held_out_norm_error(const std::vector<processing::StaticPoint>& intervals, double gravity_mps2,
                                     const CalibrationOptions& options = {});
// The same for the known-orientation fit (truth_f[k]: interval k's true specific force [m/s^2];
// |correct(ȳ_k)| − |truth_f[k]| on the one left out).
HeldOutNormError held_out_norm_error(const std::vector<processing::StaticPoint>& intervals,
                                     const std::vector<Eigen::Vector3d>& truth_f, const CalibrationOptions& options = {});

// Truth from the columns f_x_mps2, f_y_mps2, f_z_mps2 (processing's truth mean over each
// interval; intervals without truth are dropped).
CalibrationResult calibrate_accelerometer_known_orientations(const Recording& rec,
                                                             const CalibrationOptions& options = {});
// truth_f[k]: the true specific force of interval k in the sensor frame [m/s^2].
CalibrationResult calibrate_accelerometer_known_orientations(
    const std::vector<processing::StaticPoint>& intervals, const std::vector<Eigen::Vector3d>& truth_f,
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
  // Rate table intervals; turns and earth_rate take their still segments with these settings (the
  // kinds orientation and detected; settle_s = segment_trim_s) and their turns untrimmed.
  processing::ProcessingOptions processing = rate_table_interval_options();
  // Turns: how well a known turn is known [deg, 1σ], in angle and in axis direction: the integrated
  // turn v_k gets the a-priori variance σ² along the turn's axis and (|θ_k|·σ)² across it [rad²].
  double turn_angle_sigma_deg = 1.0;
  // Rate table: how well each interval's rate axis is known in the sensor frame (the sensor placed on
  // the table) [deg, 1σ about each perpendicular]; 0: exactly (a bench run's truth: the relative
  // weighting). > 0: each interval mean is whitened by its a-priori sigmas — the noise of the mean,
  // |ω|·σ across the rate, |ω|·σ² along it (the cosine loss, half of it taken off the stated rate),
  // and the Earth rate the truth leaves out (its horizontal part turns with the table: Ω_e² on each
  // horizontal axis at most) — and the covariance is scaled by the reduced χ² only when it exceeds 1.
  double rate_axis_sigma_deg = 0.0;
  // Earth rate: the placement of the up and down positions [deg, 1σ of each tilt component]: the
  // projection on the stated vertical then also sees the horizontal readings (the other axes'
  // biases) by the tilt, σ·|ȳ_⊥| per still. The model file's orientation_sigma_deg.
  double orientation_sigma_deg = 0.0;
  // The gyro's g-sensitivity where it is not estimated, as an a-priori spread of each G_ij
  // [(deg/s)/g, 1σ]; 0: none (a navigation-grade gyro). Earth rate: up and down flip it with the
  // Earth rate, so a scale_i reads as scale_i + G_ii·g/Ω_v: the stills' projections get the joint
  // covariance g_k·g_l·σ_G²·(u_k·u_l)², which widens the scales by g·σ_G/Ω_v (≈ 33 for an
  // MPU-6050's 0.1). Rate table with rate_axis_sigma_deg > 0 and no g-sensitivity estimated: the
  // intervals get σ_G²·(f_k·f_l) on each axis jointly (legs with one axis up share G·f with the
  // bias: with the axes up only, never down, the bias is known no better than G·g).
  double g_sensitivity_sigma_dps_per_g = 0.0;

  bool IsValid(std::string* error = nullptr) const;  // as CalibrationOptions::IsValid
};

model::ErrorModel gyroscope_model(bool g_sensitivity);

// Rate table from a recording: segments of kind "rate" and "orientation" (options.processing)
// with the truth columns w_x_radps.. and f_x_mps2..; fails when the recording has none.
CalibrationResult calibrate_gyro_rate_table(const Recording& rec, const GyroOptions& options = {});
// truth_w[k], truth_f[k]: true rate [rad/s] and specific force [m/s^2] of interval k (sensor frame).
CalibrationResult calibrate_gyro_rate_table(const std::vector<processing::StaticPoint>& intervals,
                                            const std::vector<Eigen::Vector3d>& truth_w,
                                            const std::vector<Eigen::Vector3d>& truth_f,
                                            const GyroOptions& options = {});
// Integration between the static intervals of a successful accelerometer calibration (its
// intervals index rec.samples). Fails when `accel` failed or fewer than 7 intervals remain.
CalibrationResult calibrate_gyro_integration(const Recording& rec, const CalibrationResult& accel,
                                             const GyroOptions& options = {});

// (c) Turns by known angles (Ferraris): bias (and G) from the still segments (kinds orientation and
//     detected, trimmed), scale and cross-axis from the recording's kRotation segments with the
//     truth columns turn_<axis>_deg (stend/recording/truth_columns.hpp): the reading integrated
//     over turn k, v_k = Σ ω_i Δt, against T_k·measure(θ, θ_k/T_k, F_k/T_k) = A(θ)·θ_k + b·T_k
//     (+ G·F_k, F_k = Σ f_i Δt of the measured specific force). One weighted least-squares fit of
//     the still means and the turn integrals, whitened jointly by a-priori sigmas: still mean σ_n/√N
//     (σ_n the per-sample gyro noise pooled over the stills, at least the quantization step/√12,
//     times their correlation factor) plus the Earth rate the truth leaves out (its horizontal part,
//     one value for the stills at one orientation); turn integral σ_n·Δt·√N, plus
//     turn_angle_sigma_deg along the turn's axis and |θ_k|·that across it. Covariance (JᵀJ)⁻¹ of the
//     whitened problem, scaled by the reduced χ² only when it exceeds 1 (the turns' sigma is a stated
//     bound; CalibrationResult::uncertainty says which). Turns about fewer than three independent
//     axes: the fit fails naming the combination it cannot see.
// `accel`, when given (a successful accelerometer fit of the same recording, as the model file's
// accelerometer part runs first), calibrates the specific force the g-sensitivity sees (else the raw
// accelerometer reading, whose bias would pass into the gyro bias as G·b).
CalibrationResult calibrate_gyro_turns(const Recording& rec, const GyroOptions& options = {},
                                       const CalibrationResult* accel = nullptr);
// A turn given directly: its window (mean gyro and specific-force readings, samples_used, first
// and last sample times) and the rotation it made [rad, sensor frame]. Each of its samples stands
// for sample_period_s: the recording's sample period (1 / its rate: a bursty log's mean rate, whose
// stamps inside a turn say when the samples arrived, not when they were taken); 0: the window's
// own, its duration over its sample intervals.
struct KnownTurn {
  processing::StaticPoint window;
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();
  double sample_period_s = 0.0;
};
// `stills[k].stimulus.input`: the applied rate of still k (Earth rate, or 0) [rad/s];
// quantization_radps: one count of the gyro (0: unknown).
CalibrationResult calibrate_gyro_turns(const std::vector<processing::StaticPoint>& stills,
                                       const std::vector<KnownTurn>& turns, const GyroOptions& options = {},
                                       double quantization_radps = 0.0);

// (d) Earth rate in up/down positions at a known latitude: for every still with finite truth f_k
//     and w_k, u_k = f_k/|f_k|, Ω_v,k = u_k·w_k; observation z_k = u_k·ȳ_k against
//     u_k·measure(θ, Ω_v,k·u_k) = u_k·b + u_k·A(θ)·(Ω_v,k u_k). Bias and scale of each axis that is
//     near vertical (|u_k,i| ≥ cos 45°) in some still; the others, and every cross-axis term (seen only
//     as m_ij + m_ji, and only in tilted positions), are held at 0 and said so. Whitened jointly by
//     the a-priori covariance of the z_k: the pooled still noise projected on u_k, /√N; the tilt of
//     each position (orientation_sigma_deg) times its horizontal reading; the unmodelled
//     g-sensitivity (g_sensitivity_sigma_dps_per_g), shared as g_k·g_l·σ_G²·(u_k·u_l)². Covariance
//     scaled by the reduced χ² when dof > 0.
//     The Earth rate is small (≤ 7.3e-5 rad/s): on a consumer gyro the scale comes out imprecise.
CalibrationResult calibrate_gyro_earth_rate(const Recording& rec, const GyroOptions& options = {});
// truth_f[k], truth_w[k]: the still's specific force [m/s^2] and applied rate [rad/s] (sensor frame).
CalibrationResult calibrate_gyro_earth_rate(const std::vector<processing::StaticPoint>& stills,
                                            const std::vector<Eigen::Vector3d>& truth_f,
                                            const std::vector<Eigen::Vector3d>& truth_w,
                                            const GyroOptions& options = {}, double quantization_radps = 0.0);

const char* loss_name(Loss l);
Loss loss_from_name(const std::string& name);  // "none" | "huber" | "cauchy"; throws otherwise

}  // namespace stend::ceres_nonlinear
