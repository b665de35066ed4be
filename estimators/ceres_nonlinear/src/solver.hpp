// Internal to ceres_nonlinear: what the four procedures share — the parameter vector, the robust
// loss, the solve with its identifiability check and covariance (stend/estimation/
// identifiability.hpp), and the bookkeeping of a failed fit. See stend/ceres_nonlinear/calibration.hpp.
#pragma once

#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/sdk.hpp>

#include <ceres/ceres.h>

#include <limits>
#include <string>
#include <vector>

namespace stend::ceres_nonlinear::detail {

inline constexpr int kFull = 12;  // bias 3, scale 3, cross 6

// On the operator() of a fixed-size autodiff cost: everything it calls (the error model's affine
// form on Jets, Eigen's Jet arrays) is inlined into it. Left to its heuristics GCC 12 kept Eigen's
// Jet array constructor out of line once the procedures had a file each: the same 1,500 cost
// evaluations of a 150-position fit took 7.5 % more instructions (callgrind), the fit 5–9 % more time.
// Not under the sanitizers (STEND_SANITIZE, the fuzz build): flattening their instrumented Jet code
// takes a compiler over ten minutes and 3 GB per file.
#if defined(__SANITIZE_ADDRESS__)
#define STEND_CERES_COST_INLINE
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define STEND_CERES_COST_INLINE
#endif
#endif
#ifndef STEND_CERES_COST_INLINE
#define STEND_CERES_COST_INLINE [[gnu::flatten]]
#endif

// `full` (kFull entries) from the free parameters: free_index[k] is the position of free parameter
// k in the full vector; the others are 0.
template <typename T>
void expand(const T* free_params, const std::vector<int>& free_index, T* full) {
  for (int i = 0; i < kFull; ++i) full[i] = T(0);
  for (std::size_t k = 0; k < free_index.size(); ++k) full[free_index[k]] = free_params[k];
}

// Huber or Cauchy at the options' scale; nullptr (squared loss) for Loss::kNone.
ceres::LossFunction* make_loss(const CalibrationOptions& o);

// The solver settings of the gyro fits as the shared solve reads them, with `loss_scale` the scale
// of their residual (rad/s on the rate table, rad in the integration).
CalibrationOptions as_calibration_options(const GyroOptions& g, double loss_scale);

// r.parameters for the model's parameters; those not in `free_index` held at 0 by the frame
// convention.
void init_parameters(CalibrationResult& r, const std::vector<int>& free_index);

// Marks the fit failed: the message, θ NaN, every estimated parameter without a number.
void fail_all(CalibrationResult& r, const std::string& message);

// How a procedure weights its residuals, and so where the scale of its covariance comes from.
enum class Weighting {
  // Unit (or relative) weights: covariance (JᵀJ)⁻¹ scaled by σ² = RSS/(n − p); needs n > p.
  kRelative,
  // Residuals whitened by a-priori sigmas: covariance (JᵀJ)⁻¹ scaled by the reduced χ² = RSS/(n − p)
  // when n > p (Student t intervals), else the a-priori covariance as it is (normal quantile).
  kAPriori,
  // Residuals whitened by a-priori sigmas some of which are stated bounds (a placement "within about
  // a degree"): covariance (JᵀJ)⁻¹ scaled by the reduced χ² only when it exceeds 1 (Student t
  // intervals), else the a-priori covariance (normal quantile). A placement better than stated makes
  // the χ² small, but that says nothing about the noise of the means beside it: it never narrows the
  // intervals.
  kAPrioriAtLeast,
};

// Solve, check identifiability, fill the covariance. `free_index` lists the estimated parameters;
// x holds their start and, on return, their solution. r.uncertainty gets the covariance's source
// appended (after what the procedure wrote there: its sigmas).
void solve(ceres::Problem& problem, std::vector<double>& x, const std::vector<int>& free_index, int residual_count,
           const CalibrationOptions& o, CalibrationResult& r, Weighting weighting = Weighting::kRelative);

// How much more the intervals' means scatter than white noise of their sample spread says: the
// pooled ratio √(Σ correlated_std_error² / Σ std_error²) over the intervals and axes of one
// instrument (processing's Newey–West error of a mean: a sensor's low-pass filter correlates nearby
// samples), at least 1 (1 when nothing is known). The a-priori noise of a mean is σ/√N times this.
double noise_correlation_factor(const std::vector<processing::StaticPoint>& points, bool gyro);

// Whether every interval's accelerometer and gyro means are finite (a method reading both).
bool finite_intervals(const std::vector<processing::StaticPoint>& intervals);
// Whether every interval's mean of one instrument is finite (a method reading that one alone: the
// other may be absent from the recording, its values NaN).
bool finite_accel_means(const std::vector<processing::StaticPoint>& intervals);
bool finite_gyro_means(const std::vector<processing::StaticPoint>& intervals);

// Whether the noise of the intervals' means of the instrument (gyro or accelerometer) is unknown:
// no interval's standard error is a number above rounding (1e-12 of the mean) — a table of means
// that does not state both n and sigma (each row's mean held: processing::HeldMean), or an
// instrument the recording holds no samples of. Then standard errors come from the residual
// scatter, never from a spread of zero. False for no intervals.
bool mean_noise_unknown(const std::vector<processing::StaticPoint>& intervals, bool gyro);

// How the rows of a table of means weight a fit (processing::HeldMean, whose std_error() is the one
// rule): kNone — not every interval is a held row stating n or sigma (then the intervals weigh the
// same and the spread comes from the residuals); kRelative — n or sigma alone (the weights are
// relative, their scale from the residuals); kAbsolute — both (sigma/√n: a-priori sigmas).
enum class HeldWeighting { kNone, kRelative, kAbsolute };
struct HeldWeights {
  HeldWeighting kind = HeldWeighting::kNone;
  // Per interval, the standard error of its accelerometer mean [m/s²]; kRelative: scaled to an RMS
  // of 1 over the table (so a residual scale reads in m/s² for a row of typical weight).
  std::vector<Eigen::Vector3d> std_error;
  // "the rows' stated sigma/√n (a table of means)", … for the uncertainty line.
  std::string text() const;
};
HeldWeights held_weights(const std::vector<processing::StaticPoint>& intervals);

// Per-axis RMS of reading − truth, raw and calibrated with r's θ (f: the specific force of each
// interval for the model's g-sensitivity; truth when empty) into r.truth_error_axis.
void axis_rms_against(CalibrationResult& r, const std::vector<Eigen::Vector3d>& truth,
                      const std::vector<Eigen::Vector3d>& reading, const std::vector<Eigen::Vector3d>& f);

// The intervals of a recording through the processing stage, with the truth means of the
// requested columns per interval and how they were detected.
struct Extracted {
  std::vector<processing::StaticPoint> intervals;
  std::vector<std::vector<double>> truth;  // per interval, the means of the requested columns
  std::optional<processing::DetectionSummary> detection;
};
Extracted extract_intervals(const Recording& rec, const processing::ProcessingOptions& o,
                            std::vector<std::string> truth_columns = {});

}  // namespace stend::ceres_nonlinear::detail
