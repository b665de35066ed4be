// temp_poly as an estimator plugin (kind estimator): bias and scale versus temperature, options
// from the model YAML (load_options) — the same as the built-in `stend fit` path.
#include <stend/sdk.hpp>
#include <stend/temp_poly/temp_poly.hpp>

#include <cmath>
#include <sstream>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", "temp_poly.json", NAN, NAN, nullptr, "default name of the results file"},
};

class TempPolyEstimator final : public stend::Estimator {
 public:
  explicit TempPolyEstimator(const stend::Params& p) {
    if (p.has("results_file")) name_ = p.string("results_file");
  }
  stend::EstimatorResult fit(const stend::EstimatorRequest& req) override {
    if (req.recording == nullptr) throw std::invalid_argument("temp_poly: no recording given");
    const auto r = stend::temp_poly::fit_temperature_model(*req.recording, stend::temp_poly::load_options(req.model_file));
    std::ostringstream text;
    stend::temp_poly::print_report(text, r);
    return {r.ok, r.ok ? std::string() : "the temp_poly fit failed (see the report)", stend::temp_poly::to_json(r),
            text.str(), name_};
  }

 private:
  std::string name_ = "temp_poly.json";
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, "temp_poly", "0.1.0",
                    "Bias and scale versus temperature (polynomial order by cross-validation or BIC)", kParams,
                    TempPolyEstimator)
