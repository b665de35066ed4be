// temp_poly behind the SDK's Estimator interface: the same class is the built-in registry's entry
// and the estimator plugin stend_temp_poly.so.
#pragma once

#include <stend/estimation/registry.hpp>
#include <stend/sdk.hpp>

#include <nlohmann/json_fwd.hpp>

namespace stend::temp_poly {

inline constexpr const char* kResultsFile = "temp_poly.json";
inline constexpr const char* kDescription =
    "Bias and scale versus temperature (polynomial order by cross-validation or BIC)";

class TempPolyEstimator final : public Estimator {
 public:
  explicit TempPolyEstimator(const Params& params = {});
  // The plugin's configuration: the results file name, defaulting to kResultsFile.
  static const stend::fields::Table<estimation::EstimatorConfig>& fields();
  // Fits the model file (load_options) to the recording: the report and stend.temp_poly/1.
  EstimatorResult fit(const EstimatorRequest& request) override;

 private:
  estimation::EstimatorConfig config_;
};

// temp_poly.json read back (src/result_io.cpp, beside its writer to_json): the summary lists every
// fitted axis's parameters; the instrument model merges the axes' fits (Coverage::kAxes, the
// axes that succeeded; the failed ones named), with the reference temperature and the temperature
// range the fit saw.
estimation::FitResult read_results(const nlohmann::json& doc);

// Registry entry: claims model files with temperature-model options (`selection:`, `max_order:`);
// fits and reads through the typed result.
estimation::EstimatorEntry estimator_entry();

}  // namespace stend::temp_poly
