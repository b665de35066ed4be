// allan as an estimator plugin (kind estimator): overlapping Allan deviation and noise
// identification, options from the model YAML's `allan:` mapping — the same as the built-in
// `stend fit` path.
#include <stend/allan/allan.hpp>
#include <stend/sdk.hpp>

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <sstream>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", "allan.json", NAN, NAN, nullptr, "default name of the results file"},
};

class AllanEstimator final : public stend::Estimator {
 public:
  explicit AllanEstimator(const stend::Params& p) {
    if (p.has("results_file")) name_ = p.string("results_file");
  }
  stend::EstimatorResult fit(const stend::EstimatorRequest& req) override {
    if (req.recording == nullptr) throw std::invalid_argument("allan: no recording given");
    const YAML::Node root = YAML::LoadFile(req.model_file);
    const auto report =
        stend::allan::analyze_recording(*req.recording, stend::allan::options_from_yaml(root["allan"], req.model_file));
    std::ostringstream text, json;
    stend::allan::write_summary_table(text, report);
    stend::allan::write_json(json, report);
    return {true, {}, json.str(), text.str(), name_};
  }

 private:
  std::string name_ = "allan.json";
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, "allan", "0.1.0",
                    "Overlapping Allan deviation with confidence intervals and noise identification", kParams,
                    AllanEstimator)
