// allan behind the SDK's Estimator interface: the same class is the built-in registry's entry and
// the estimator plugin stend_allan.so.
#pragma once

#include <stend/estimation/registry.hpp>
#include <stend/sdk.hpp>

#include <nlohmann/json_fwd.hpp>

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

// allan.json read back: the summary lists N, K and B (and G, Tc where fitted) of every channel
// whose noise model was fitted (N_ax, K_gz, …), a channel whose model failed named in the
// message; the typed noise holds N, K, B per accelerometer and gyroscope channel and, per sensor,
// the Kalibr block's stand-in for a density no axis identified.
estimation::FitResult read_results(const nlohmann::json& doc);

// Registry entry: claims model files with a top-level `allan:` mapping; fits and reads through
// the typed result (fit_typed writes allan.json and reads it back).
estimation::EstimatorEntry estimator_entry();

}  // namespace stend::allan
