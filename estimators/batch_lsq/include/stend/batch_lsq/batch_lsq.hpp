// Batch least-squares estimation of an error model from static orientations — the paper's
// procedure (Aksenov, eq. (7)–(9) and the calibration steps), made honest:
//   1. per static segment (kind "orientation" by default): the constant part of each output axis
//      by a Butterworth low-pass (order, cutoff_hz stated), settle_s discarded at both ends,
//      averaged — the processing stage (stend/processing/static_points.hpp), whose rules skip
//      unsettled, incomplete, saturated and too short segments;
//   2. the truth over the same window from the recording's truth columns (f_*_mps2 / w_*_radps,
//      die_c; processing's truth mean), giving Δa = measured − true input per axis;
//   3. one design row per (orientation, fitted axis) from ErrorModel::regressor at the mean truth
//      stimulus — never a re-written term formula;
//   4. weighted linear least squares by SVD on the column-scaled design
//      (stend/estimation/linear_lsq.hpp): values, standard errors, Student-t intervals, rank,
//      condition number, identifiability (zero columns, aliased groups with the combinations the
//      data do identify).
// Parameters of the model that cannot affect the fitted axes (e.g. bias_x when axes = [z]) are
// left out of the fit and listed in FitResult::excluded.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <iosfwd>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "stend/estimation/model_spec.hpp"
#include "stend/estimation/linear_lsq.hpp"
#include "stend/model/terms.hpp"
#include "stend/processing/static_points.hpp"
#include "stend/recording/recording.hpp"

namespace stend::batch_lsq {

using estimation::ModelSpec;  // the model file (stend/estimation/model_spec.hpp)

inline constexpr const char* kFitSchema = "stend.fit/1";
inline constexpr const char* kEstimatorName = "batch_lsq";
inline constexpr const char* kEstimatorVersion = "0.1.0";

// One static orientation: what the sensor read (constant part) and what the bench applied — this
// estimator's view of a processing::StaticPoint.
struct StaticPoint {
  int segment_id = -1;
  std::string label;
  double t_start_s = 0.0, t_end_s = 0.0;  // the kept window (after settle_s at each end)
  std::size_t samples_used = 0;
  Eigen::Vector3d measured = Eigen::Vector3d::Zero();  // per output axis, instrument unit
  // White-noise standard error of each mean (raw std / √n); NaN when unknown.
  Eigen::Vector3d measured_std_error = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  model::Stimulus<double> stimulus;  // truth at this orientation (mean over the window)
};

struct Residual {
  int point = 0;  // index into FitResult::points
  int axis = 0;
  double observed = 0.0;  // Δ = measured − true input
  double fitted = 0.0;    // Φ·θ̂
  double residual = 0.0;  // observed − fitted
};

struct FitResult {
  bool ok = false;
  std::string message;  // why the fit failed (empty on success)
  ModelSpec spec;
  std::string recording_dir, experiment_name, recording_status;
  bool extracted = false;  // points came from static extraction (fit_recording), not given
  std::vector<StaticPoint> points;
  std::vector<std::string> notes;  // skipped segments, extraction remarks, data-source remarks

  std::vector<model::ParamInfo> params;  // the fitted parameters (LSQ columns)
  std::vector<int> param_index;          // their index in the model's flat parameter vector
  std::vector<std::string> excluded;     // model parameters that cannot affect the fitted axes
  estimation::LsqResult lsq;
  std::vector<Residual> residuals;

  // Per axis (x, y, z), NaN for axes not fitted: RMS of the residuals in the instrument unit
  // (m/s² or rad/s) and in the display unit (mg or deg/h).
  Eigen::Vector3d residual_rms = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d residual_rms_display = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::string unit;          // "m/s^2" | "rad/s"
  std::string display_unit;  // "mg" | "deg/h"

  // The model's full flat parameter vector: fitted identifiable values, NaN for non-identifiable
  // and excluded parameters.
  Eigen::VectorXd theta_full() const;
};

// Step 1–2 for every usable segment, through the processing stage with spec.processing (completed
// by the recording's experiment `processing:` section). Segments that are unsettled, incomplete,
// saturated, too short or without truth are skipped; `extraction` (optional) receives the stage's
// result: the skips with their reasons, the notes, the options used. Throws std::runtime_error
// when the recording lacks what the model needs (truth columns), naming the missing columns and
// those present, or its sample times do not increase.
std::vector<StaticPoint> extract_points(const Recording& recording, const ModelSpec& spec,
                                        processing::Extraction* extraction = nullptr);

// Steps 3–4 on given points (synthetic data, tables typed from papers, or extract_points).
FitResult fit_points(const std::vector<StaticPoint>& points, const ModelSpec& spec);

// The whole procedure on a recording. Never throws for data problems: a failed fit returns
// ok = false with the reason.
FitResult fit_recording(const Recording& recording, const ModelSpec& spec);

// Text report: data used, extraction settings, parameter table (parameter, value, unit, std error,
// interval, identifiable yes/no + reason), aliased groups, residual RMS per axis, condition
// number, warnings and notes. A failed fit prints FIT FAILED and the reason, no numbers.
void print_table(std::ostream& os, const FitResult& fit);
std::ostream& operator<<(std::ostream& os, const FitResult& fit);  // = print_table

// JSON document of schema "stend.fit/1" (estimators/batch_lsq/README.md).
std::string to_json(const FitResult& fit, int indent = 2);
// Through stend::write_file_atomic: throws IoError when the file cannot be written.
void write_json(const std::filesystem::path& file, const FitResult& fit);

}  // namespace stend::batch_lsq
