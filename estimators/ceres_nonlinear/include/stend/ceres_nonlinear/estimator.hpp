// ceres_nonlinear behind the SDK's Estimator interface: the same class is the built-in registry's
// entry and the estimator plugin stend_ceres_nonlinear.so.
#pragma once

#include <stend/estimation/registry.hpp>
#include <stend/sdk.hpp>

namespace stend::ceres_nonlinear {

inline constexpr const char* kResultsFile = "ceres.json";
inline constexpr const char* kDescription =
    "Ceres multi-position accelerometer and gyro calibration (known/unknown orientations, rate table, "
    "integration)";

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

// Registry entry: claims model files with a top-level `ceres_nonlinear:` mapping.
estimation::EstimatorEntry estimator_entry();

}  // namespace stend::ceres_nonlinear
