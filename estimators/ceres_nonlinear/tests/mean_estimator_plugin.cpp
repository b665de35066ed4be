// A minimal estimator plugin built like an out-of-tree one (its own folder, found through
// STEND_PLUGIN_PATH only): the mean accelerometer reading of the recording. ceres_cli_test checks
// that `stend fit --estimator mean_accel` routes to it.
#include <stend/recording/recording.hpp>
#include <stend/sdk.hpp>

#include <cmath>
#include <string>

namespace {

const stend_param_spec kParams[] = {
    {"results_file", "string", "", "mean_accel.json", NAN, NAN, nullptr, "default name of the results file"},
};

class MeanAccel final : public stend::Estimator {
 public:
  explicit MeanAccel(const stend::Params&) {}
  stend::EstimatorResult fit(const stend::EstimatorRequest& req) override {
    const auto& s = req.recording->samples;
    if (s.empty()) return {false, "no samples", "{}", "mean_accel: no samples\n", "mean_accel.json"};
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (const auto& x : s) m += x.accel_mps2;
    m /= static_cast<double>(s.size());
    const std::string json = "{\"schema\": \"test.mean_accel/1\", \"samples\": " + std::to_string(s.size()) +
                             ", \"mean_mps2\": [" + std::to_string(m[0]) + ", " + std::to_string(m[1]) + ", " +
                             std::to_string(m[2]) + "]}";
    return {true, {}, json, "mean_accel: " + std::to_string(s.size()) + " samples\n", "mean_accel.json"};
  }
};

}  // namespace

STEND_DEFINE_PLUGIN(STEND_KIND_ESTIMATOR, "mean_accel", "0.0.1", "Test estimator: mean accelerometer reading",
                    kParams, MeanAccel)
