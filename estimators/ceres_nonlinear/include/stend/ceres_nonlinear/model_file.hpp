// The ceres_nonlinear estimator driven by a model YAML file (`stend fit RUN --model FILE`):
//
//   ceres_nonlinear:
//     accelerometer: unknown_orientations   # unknown_orientations | known_orientations | none
//     gyroscope: integration                # integration | rate_table | turns | earth_rate | bias_only | none
//     intervals: detect                     # detect | segments | auto (processing's keys: intervals,
//                                           #   segments, extraction, detector)
//     ...                                   # options: see README.md, "Model file"
//
// Every key is checked (unknown keys with "did you mean", wrong types, ranges); errors are
// stend::ExperimentError naming file:line:col and what was expected.
#pragma once

#include <stend/ceres_nonlinear/calibration.hpp>
#include <stend/errors.hpp>  // ExperimentError
#include <stend/recording/recording.hpp>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>
#include <yaml-cpp/yaml.h>

namespace stend::ceres_nonlinear {

inline constexpr const char* kResultsSchema = "stend.ceres_nonlinear.results/1";
inline constexpr const char* kEstimatorName = "ceres_nonlinear";
inline constexpr const char* kEstimatorVersion = "0.2.0";
// gravity_mps2: recording_or_standard — the recording's g where it states one (a stend run: from
// the experiment's site), else standard gravity (an imported log states none).
inline constexpr const char* kRecordingOrStandardGravity = "recording_or_standard";

// The `gyroscope:` methods: integration, rate_table, turns, earth_rate, bias_only (the
// accelerometer fit's still means), none.
inline const std::vector<std::string> kGyroscopeMethods = {"integration", "rate_table", "turns", "earth_rate",
                                                           "bias_only", "none"};

struct ModelFileOptions {
  std::string accelerometer = "unknown_orientations";
  std::string gyroscope = "integration";
  CalibrationOptions accel;
  GyroOptions gyro;
  // What the file asks for that no longer acts, said in the report (e.g. `max_std_error`,
  // superseded by the per-parameter verdicts and `tolerances`).
  std::vector<std::string> warnings;

  // Known methods (and a gyroscope method the accelerometer method allows), and both parts'
  // options valid (CalibrationOptions::IsValid, GyroOptions::IsValid).
  bool IsValid(std::string* error = nullptr) const;
};

// Reads the `ceres_nonlinear:` mapping of `root` (loaded from `file`).
ModelFileOptions options_from_yaml(const YAML::Node& root, const std::string& file);
ModelFileOptions load_model_file(const std::string& file);

// The options as text with units (echoed at the top of the report) and as JSON.
std::string describe_options(const ModelFileOptions& o);
std::string options_json(const ModelFileOptions& o);

struct ModelFileFit {
  // kOk when every requested part succeeded or was not applicable and one gave a result
  // (estimation::combined_status); kNotApplicable when none applied.
  estimation::FitStatus status = estimation::FitStatus::kFailed;
  std::string message;  // the failed parts and why (none applied: why not)
  // A part whose instrument the recording lacks (estimation::why_absent): "gyroscope: not
  // applicable — why". Such a part has no numbers and never makes the fit fail.
  std::vector<std::string> notes;
  CalibrationResult accel, gyro;
  bool has_accel = false, has_gyro = false;
  std::string text;  // options echo + both reports
  nlohmann::json document;  // the results document (results_document); written as document.dump(2)

  bool ok() const { return status == estimation::FitStatus::kOk; }
};

// The results document of a model-file fit (schema kResultsSchema, README.md): the options used,
// each part's result, a flat parameter list (accel_*, gyro_*, table_offset_*) and the summary
// fields (src/result_writer.cpp; read back by read_results, estimator.hpp).
nlohmann::json results_document(const ModelFileOptions& options, const ModelFileFit& fit);

// Runs what the options ask for: accelerometer first (the integration method needs it), then the
// gyroscope — not applicable, with no gyro bias estimated either, when the recording has no
// gyroscope (SensorInfo::has_gyro false). status kOk only when no requested part failed and one
// gave a result. Processing keys the model file does not
// state come from the recording's experiment `processing:` section (processing::resolve); the
// echoed options are the ones used.
ModelFileFit fit_model_file(const Recording& rec, const ModelFileOptions& options);

}  // namespace stend::ceres_nonlinear
