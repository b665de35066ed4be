// batch_lsq behind the SDK's Estimator interface: the same class is the built-in registry's entry
// and the estimator plugin stend_batch_lsq.so.
#pragma once

#include <stend/estimation/registry.hpp>
#include <stend/sdk.hpp>

namespace stend::batch_lsq {

inline constexpr const char* kResultsFile = "fit.json";
inline constexpr const char* kDescription =
    "The paper's batch least squares over static orientations (error-model terms)";

class BatchLsqEstimator final : public Estimator {
 public:
  explicit BatchLsqEstimator(const Params& params = {});
  // The plugin's configuration: the results file name, defaulting to kResultsFile.
  static const stend::fields::Table<estimation::EstimatorConfig>& fields();
  // Fits the model file (load_model_spec) to the recording: the text table and stend.fit/1.
  EstimatorResult fit(const EstimatorRequest& request) override;

 private:
  estimation::EstimatorConfig config_;
};

// Registry entry: the fallback for model files no other estimator claims.
estimation::EstimatorEntry estimator_entry();

}  // namespace stend::batch_lsq
