// allan behind the SDK's Estimator interface: the same class is the built-in registry's entry and
// the estimator plugin stend_allan.so.
#pragma once

#include <stend/estimation/registry.hpp>
#include <stend/sdk.hpp>

namespace stend::allan {

inline constexpr const char* kResultsFile = "allan.json";
inline constexpr const char* kDescription =
    "Overlapping Allan deviation with confidence intervals and noise identification";

class AllanEstimator final : public Estimator {
 public:
  explicit AllanEstimator(const Params& params = {});
  // The plugin's configuration: the results file name, defaulting to kResultsFile.
  static const stend::fields::Table<estimation::EstimatorConfig>& fields();
  // Options from the model file's `allan:` mapping: the summary table and allan.json.
  EstimatorResult fit(const EstimatorRequest& request) override;

 private:
  estimation::EstimatorConfig config_;
};

// Registry entry: claims model files with a top-level `allan:` mapping; its summary lists N, K
// and B of every channel whose noise model was fitted (N_ax, K_gz, …); a channel whose model
// failed is named in the message.
estimation::EstimatorEntry estimator_entry();

}  // namespace stend::allan
