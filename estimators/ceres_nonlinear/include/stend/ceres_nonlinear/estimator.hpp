// ceres_nonlinear behind the SDK's Estimator interface: the same class is the built-in registry's
// entry and the estimator plugin stend_ceres_nonlinear.so.
#pragma once

#include <stend/estimation/registry.hpp>
#include <stend/sdk.hpp>

#include <nlohmann/json_fwd.hpp>

namespace stend::ceres_nonlinear {

inline constexpr const char* kResultsFile = "ceres.json";
inline constexpr const char* kDescription =
    "Ceres multi-position accelerometer and gyro calibration (known/unknown orientations, rate table, "
    "integration, known turns, Earth rate)";

class CeresNonlinearEstimator final : public Estimator {
 public:
  explicit CeresNonlinearEstimator(const Params& params = {});
  // The plugin's configuration: the results file name, defaulting to kResultsFile.
  static const stend::fields::Table<estimation::EstimatorConfig>& fields();
  // Runs what the model file's `ceres_nonlinear:` mapping asks for (fit_model_file).
  EstimatorResult fit(const EstimatorRequest& request) override;

 private:
  estimation::EstimatorConfig config_;
};

// ceres.json read back (src/result_reader.cpp): the summary of the flat parameter list
// (accel_*, gyro_*); one model of the three axes per instrument part (each with its own status;
// the parameters the frame convention holds at 0 marked held and named in a note), the
// accelerometer's with the gravity it used; with `gyroscope: bias_only` the accelerometer fit's
// gyro bias as a bias-only gyroscope model.
estimation::FitResult read_results(const nlohmann::json& doc);

// Registry entry: claims model files with a top-level `ceres_nonlinear:` mapping; fits and reads
// through the typed result.
estimation::EstimatorEntry estimator_entry();

}  // namespace stend::ceres_nonlinear
