// Batch least-squares estimation of an error model from static orientations — the paper's
// procedure (Aksenov, eq. (7)–(9) and the calibration steps), made honest. The fit itself is
// estimation's shared static fit (stend/estimation/static_fit.hpp: processing stage, one design
// row per (orientation, fitted axis) from ErrorModel::regressor, weighted linear least squares by
// SVD with identifiability); this estimator adds where the points came from, the notes, the text
// table and the stend.fit/1 document.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include "stend/estimation/model_spec.hpp"
#include "stend/estimation/static_fit.hpp"
#include "stend/model/terms.hpp"
#include "stend/processing/static_points.hpp"
#include "stend/recording/recording.hpp"

namespace stend::batch_lsq {

using estimation::ModelSpec;  // the model file (stend/estimation/model_spec.hpp)

inline constexpr const char* kFitSchema = "stend.fit/1";
inline constexpr const char* kEstimatorName = "batch_lsq";
inline constexpr const char* kEstimatorVersion = "0.1.0";

// A fit: the shared static fit and where its points came from.
struct FitResult : estimation::StaticFit {
  ModelSpec spec;
  std::string recording_dir, experiment_name, recording_status;
  bool extracted = false;  // points came from static extraction (fit_recording), not given
  std::vector<processing::StaticPoint> points;
  std::vector<std::string> notes;  // skipped segments, extraction remarks, data-source remarks

  // The model's full flat parameter vector: fitted identifiable values, NaN for non-identifiable
  // and excluded parameters.
  Eigen::VectorXd theta_full() const;
};

// The fit on given points (synthetic data, tables typed from papers, or
// estimation::extract_static_points): each point's mean of the model's instrument and its truth
// stimulus.
FitResult fit_points(const std::vector<processing::StaticPoint>& points, const ModelSpec& spec);

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
