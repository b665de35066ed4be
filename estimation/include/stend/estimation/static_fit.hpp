// The linear fit of an error model (a ModelSpec) on static points — the paper's batch least
// squares (Aksenov, eq. (7)–(9)), made honest, and shared: batch_lsq's estimator, temp_poly's
// orders and the gap diagnosis' model as given are this fit.
//   1. points: the processing stage's static points (stend/processing/static_points.hpp), each
//      with the truth the model reads as its stimulus (static_request): the true input
//      (f_<axis>_mps2 or w_<axis>_radps), a gyroscope's specific force, the die temperature;
//   2. one design row per (point, fitted axis) from ErrorModel::regressor at the point's stimulus
//      — never a re-written term formula — with the observation Δ = measured − true input;
//   3. weights: none, or 1/se² from each point's white-noise standard error of the mean
//      (ModelSpec::weighting: segment_noise), still rescaled by the residual variance;
//   4. weighted linear least squares by SVD on the column-scaled design (linear_lsq.hpp): values,
//      standard errors, Student-t intervals, rank, condition number, identifiability.
// Parameters of the model that cannot affect the fitted axes (e.g. bias_x when axes = [z]) are
// left out of the fit and listed in StaticFit::excluded.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "stend/estimation/linear_lsq.hpp"
#include "stend/estimation/model_spec.hpp"
#include "stend/estimation/summary.hpp"
#include "stend/model/terms.hpp"
#include "stend/processing/static_points.hpp"
#include "stend/recording/recording.hpp"

namespace stend::estimation {

// What a fit of `spec` asks the processing stage for: the fitted instrument's axes, and as each
// point's stimulus the true input (f_<axis>_mps2 for an accelerometer, w_<axis>_radps for a
// gyroscope) and the specific force (a gyroscope's when the recording has it). Throws InputError
// naming the missing columns and those present when an input column is missing, or when a
// g-sensitivity model lacks the specific force.
processing::Request static_request(const Recording& recording, const ModelSpec& spec);

// The processing stage on `recording` for a fit of `spec`: spec.processing completed by the
// recording's experiment `processing:` section, static_request's truth. The points, the skips
// with their reasons, the notes and the options used. Throws as static_request and
// processing::extract.
processing::Extraction extract_static_points(const Recording& recording, const ModelSpec& spec);

// One row of the fit: a point's fitted axis.
struct Residual {
  int point = 0;  // index into the fitted points
  int axis = 0;
  double observed = 0.0;  // Δ = measured − true input
  double fitted = 0.0;    // Φ·θ̂
  double residual = 0.0;  // observed − fitted
};

struct StaticFit {
  FitStatus status = FitStatus::kFailed;
  std::string message;  // why the fit failed (empty on success)
  bool ok() const { return status == FitStatus::kOk; }

  std::vector<model::ParamInfo> params;  // the fitted parameters (LSQ columns)
  std::vector<int> param_index;          // their index in the model's flat parameter vector
  std::vector<std::string> excluded;     // model parameters that cannot affect the fitted axes
  LsqResult lsq;
  std::vector<Residual> residuals;

  // Per axis (x, y, z), NaN for axes not fitted: RMS of the residuals in the instrument unit
  // (m/s² or rad/s) and in the display unit (mg or deg/h).
  Eigen::Vector3d residual_rms = Eigen::Vector3d::Constant(kNaN);
  Eigen::Vector3d residual_rms_display = Eigen::Vector3d::Constant(kNaN);
  std::string unit;          // "m/s^2" | "rad/s"
  std::string display_unit;  // "mg" | "deg/s" (estimation::display_unit)
};

// Steps 2–4 on given points (extracted, synthetic, or typed from a paper's table): each point's
// mean of spec.model's instrument (StaticPoint::axes) and its stimulus. Never throws for data
// problems: a failed fit has ok = false and the reason (no axes or terms, a point without a
// standard error under segment_noise weighting, a refused least-squares problem).
StaticFit fit_static_points(const std::vector<processing::StaticPoint>& points, const ModelSpec& spec);

}  // namespace stend::estimation
