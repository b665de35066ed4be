// ceres_nonlinear as an estimator plugin (kind estimator): `stend fit RUN --model M.yaml` routes a
// model file with a top-level `ceres_nonlinear:` mapping here (built in), and any host can load
// stend_ceres_nonlinear.so and call Estimator::fit. Same code as the built-in path.
#include <stend/ceres_nonlinear/model_file.hpp>
#include <stend/sdk.hpp>

#include <cmath>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", "ceres.json", NAN, NAN, nullptr, "default name of the results file"},
};

class CeresNonlinearEstimator final : public stend::Estimator {
 public:
  explicit CeresNonlinearEstimator(const stend::Params& p) {
    if (p.has("results_file")) name_ = p.string("results_file");
  }
  stend::EstimatorResult fit(const stend::EstimatorRequest& req) override {
    if (req.recording == nullptr) throw std::invalid_argument("ceres_nonlinear: no recording given");
    const auto f = stend::ceres_nonlinear::fit_model_file(*req.recording,
                                                          stend::ceres_nonlinear::load_model_file(req.model_file));
    return {f.ok, f.message, f.json, f.text, name_};
  }

 private:
  std::string name_ = "ceres.json";
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, "ceres_nonlinear", "0.2.0",
                    "Ceres multi-position accelerometer and gyro calibration (known/unknown orientations, rate "
                    "table, integration)",
                    kParams, CeresNonlinearEstimator)
