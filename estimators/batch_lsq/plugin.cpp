// batch_lsq as an estimator plugin (kind estimator): wraps the library's fit_recording with the
// model YAML (load_model_spec), the text table and the stend.fit/1 JSON — the same as the built-in
// `stend fit` path.
#include <stend/batch_lsq/batch_lsq.hpp>
#include <stend/sdk.hpp>

#include <cmath>
#include <sstream>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", "fit.json", NAN, NAN, nullptr, "default name of the results file"},
};

class BatchLsqEstimator final : public stend::Estimator {
 public:
  explicit BatchLsqEstimator(const stend::Params& p) {
    if (p.has("results_file")) name_ = p.string("results_file");
  }
  stend::EstimatorResult fit(const stend::EstimatorRequest& req) override {
    if (req.recording == nullptr) throw std::invalid_argument("batch_lsq: no recording given");
    const auto r = stend::batch_lsq::fit_recording(*req.recording, stend::batch_lsq::load_model_spec(req.model_file));
    std::ostringstream text;
    stend::batch_lsq::print_table(text, r);
    return {r.ok, r.ok ? std::string() : "the batch_lsq fit failed (see the report)", stend::batch_lsq::to_json(r),
            text.str(), name_};
  }

 private:
  std::string name_ = "fit.json";
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, "batch_lsq", "0.1.0",
                    "The paper's batch least squares over static orientations (error-model terms)", kParams,
                    BatchLsqEstimator)
